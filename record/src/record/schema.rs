//! JSON Schemas inferred from example messages.
//!
//! A channel's schema is inferred from its first message: objects give `properties` and
//! `required`, arrays give `items` merged from all their elements, numbers give `integer` when
//! every one seen is an integer and `number` otherwise. Where elements disagree (an `Option` that
//! is `null` in one element and a string in another) the schema lists every type seen, e.g.
//! `"type": ["null", "string"]`. A field that is `null` in the first message can only be typed
//! `null`: the schema describes what was seen, not the Rust type behind it.

use serde_json::{Map, Value, json};
use std::collections::{BTreeMap, BTreeSet};

/// The shape of the JSON values seen so far at one place in a message.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Shape {
    null: bool,
    boolean: bool,
    integer: bool,
    number: bool,
    string: bool,
    /// The merged shape of all array elements seen (`Some(Shape::default())` for only empty arrays).
    array: Option<Box<Shape>>,
    object: Option<ObjectShape>,
}

/// Properties of the objects seen, and which of them every object had.
#[derive(Debug, Clone, Default, PartialEq)]
struct ObjectShape {
    properties: BTreeMap<String, Shape>,
    required: BTreeSet<String>,
}

impl Shape {
    /// The shape of one value.
    pub(crate) fn of(value: &Value) -> Shape {
        let mut shape = Shape::default();
        shape.add(value);
        shape
    }

    /// Widens this shape so that it also describes `value`.
    fn add(&mut self, value: &Value) {
        match value {
            Value::Null => self.null = true,
            Value::Bool(_) => self.boolean = true,
            Value::Number(n) if n.is_i64() || n.is_u64() => self.integer = true,
            Value::Number(_) => self.number = true,
            Value::String(_) => self.string = true,
            Value::Array(elements) => {
                let items = self.array.get_or_insert_with(Box::default);
                for element in elements {
                    items.add(element);
                }
            }
            Value::Object(fields) => self.add_object(fields),
        }
    }

    fn add_object(&mut self, fields: &Map<String, Value>) {
        let keys: BTreeSet<String> = fields.keys().cloned().collect();
        let object = match &mut self.object {
            Some(object) => {
                object.required.retain(|k| keys.contains(k));
                object
            }
            None => self.object.insert(ObjectShape { properties: BTreeMap::new(), required: keys }),
        };
        for (key, value) in fields {
            object.properties.entry(key.clone()).or_default().add(value);
        }
    }

    /// The shape as a JSON Schema value (without `$schema` or `title`).
    pub(crate) fn to_json_schema(&self) -> Value {
        let mut types = Vec::new();
        let mut schema = Map::new();
        if let Some(object) = &self.object {
            types.push("object");
            let properties: Map<String, Value> =
                object.properties.iter().map(|(k, s)| (k.clone(), s.to_json_schema())).collect();
            schema.insert("properties".into(), Value::Object(properties));
            schema.insert("required".into(), json!(object.required));
        }
        if let Some(items) = &self.array {
            types.push("array");
            if !items.is_empty() {
                schema.insert("items".into(), items.to_json_schema());
            }
        }
        if self.string {
            types.push("string");
        }
        // An integer is a number, so a mix of both is just "number".
        if self.number {
            types.push("number");
        } else if self.integer {
            types.push("integer");
        }
        if self.boolean {
            types.push("boolean");
        }
        if self.null {
            types.push("null");
        }
        match types.as_slice() {
            [] => {}
            [one] => {
                schema.insert("type".into(), json!(one));
            }
            many => {
                schema.insert("type".into(), json!(many));
            }
        }
        Value::Object(schema)
    }

    fn is_empty(&self) -> bool {
        *self == Shape::default()
    }
}

/// The JSON Schema document of a channel named `title`, inferred from its first message.
pub(crate) fn infer(title: &str, first: &Value) -> Value {
    let mut schema = Shape::of(first).to_json_schema();
    if let Value::Object(map) = &mut schema {
        map.insert("title".into(), json!(title));
        map.insert("$schema".into(), json!("https://json-schema.org/draft/2020-12/schema"));
    }
    schema
}

#[cfg(test)]
mod tests {
    use super::*;

    fn schema_of(v: Value) -> Value {
        Shape::of(&v).to_json_schema()
    }

    #[test]
    fn scalars_map_to_their_json_types() {
        assert_eq!(schema_of(json!(null)), json!({"type": "null"}));
        assert_eq!(schema_of(json!(true)), json!({"type": "boolean"}));
        assert_eq!(schema_of(json!(3)), json!({"type": "integer"}));
        assert_eq!(schema_of(json!(-3)), json!({"type": "integer"}));
        assert_eq!(schema_of(json!(0.5)), json!({"type": "number"}));
        assert_eq!(schema_of(json!("x")), json!({"type": "string"}));
    }

    #[test]
    fn objects_list_properties_and_require_all_of_them() {
        let s = schema_of(json!({"b": 1.5, "a": {"c": "x"}}));
        assert_eq!(
            s,
            json!({
                "type": "object",
                "properties": {
                    "a": {"type": "object", "properties": {"c": {"type": "string"}}, "required": ["c"]},
                    "b": {"type": "number"}
                },
                "required": ["a", "b"]
            })
        );
    }

    #[test]
    fn array_items_merge_their_elements() {
        // Integers and floats make numbers; a key missing from one element is not required.
        let s = schema_of(json!([{"d": 1, "k": "a"}, {"d": 2.5}, {"d": 3, "k": null}]));
        assert_eq!(
            s,
            json!({
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {"d": {"type": "number"}, "k": {"type": ["string", "null"]}},
                    "required": ["d"]
                }
            })
        );
        assert_eq!(schema_of(json!([1, 2, 3])), json!({"type": "array", "items": {"type": "integer"}}));
        assert_eq!(schema_of(json!([])), json!({"type": "array"}));
        assert_eq!(
            schema_of(json!([[1.0], []])),
            json!({"type": "array", "items": {"type": "array", "items": {"type": "number"}}})
        );
    }

    #[test]
    fn the_document_carries_a_title_and_dialect() {
        let s = infer("orsa.Velocity", &json!({"v_m_s": 0.3}));
        assert_eq!(s["title"], "orsa.Velocity");
        assert_eq!(s["$schema"], "https://json-schema.org/draft/2020-12/schema");
        assert_eq!(s["properties"]["v_m_s"]["type"], "number");
    }
}
