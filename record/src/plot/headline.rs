//! The headline figures of a run, computed from the plotted data, and the behaviours' order and
//! colours shared by the map, the strip and the legend.

use super::PlotData;

/// The label of "no behaviour wired".
pub(crate) const NONE_LABEL: &str = "none";

/// The kind of the behaviour `behaviour` of `data` (its name if the data gives no kind).
pub(crate) fn kind<'a>(data: &'a PlotData<'_>, behaviour: Option<&'a str>) -> Option<&'a str> {
    behaviour.map(|b| data.kinds.get(b).map_or(b, String::as_str))
}

/// A behaviour's colour: fixed for the thesis' kinds, from a palette for others.
pub(crate) fn colour(data: &PlotData<'_>, behaviour: Option<&str>, others: &[&str]) -> &'static str {
    const PALETTE: [&str; 6] = ["#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"];
    match (kind(data, behaviour), behaviour) {
        (None, _) | (_, None) => "#9a9a9a",
        (Some("centerfollow"), _) => "#1f77b4",
        (Some("wallfollow"), _) => "#ff7f0e",
        (Some(_), Some(name)) => {
            let i = others.iter().position(|o| *o == name).unwrap_or(0);
            PALETTE[i % PALETTE.len()]
        }
    }
}

/// The behaviours in the trajectory: centerfollow, wallfollow, the others in order of first
/// appearance, then "none" (each only if present).
pub(crate) fn behaviours<'a>(data: &'a PlotData<'_>) -> Vec<Option<&'a str>> {
    let mut seen: Vec<Option<&'a str>> = Vec::new();
    for s in &data.trajectory {
        let b = s.behaviour.as_deref();
        if !seen.contains(&b) {
            seen.push(b);
        }
    }
    let rank = |b: &Option<&str>| match kind(data, *b) {
        Some("centerfollow") => 0,
        Some("wallfollow") => 1,
        Some(_) => 2,
        None => 3,
    };
    seen.sort_by_key(rank); // stable: others keep their order of appearance
    seen
}

/// The names of behaviours of kinds other than the thesis' two, in order of appearance (for
/// colours).
pub(crate) fn other_names<'a>(data: &PlotData<'_>, behaviours: &[Option<&'a str>]) -> Vec<&'a str> {
    behaviours
        .iter()
        .flatten()
        .copied()
        .filter(|b| !matches!(kind(data, Some(b)), Some("centerfollow" | "wallfollow")))
        .collect()
}

/// A duration for people: seconds, minutes or hours.
pub(crate) fn duration(seconds: f64) -> String {
    if seconds < 120.0 {
        format!("{seconds:.1} s")
    } else if seconds < 7200.0 {
        format!("{:.1} min", seconds / 60.0)
    } else {
        format!("{:.2} h", seconds / 3600.0)
    }
}

/// The headline line: duration, distance, time share per behaviour, bumps, errors.
pub(crate) fn line(data: &PlotData<'_>) -> String {
    let mut parts = Vec::new();
    let traj = &data.trajectory;
    if let (Some(first), Some(last)) = (traj.first(), traj.last()) {
        let total = last.t_s - first.t_s;
        parts.push(duration(total));
        let distance: f64 = traj.windows(2).map(|w| (w[1].x_m - w[0].x_m).hypot(w[1].y_m - w[0].y_m)).sum();
        if distance.is_finite() {
            parts.push(format!("{distance:.0} m driven"));
        }
        if total > 0.0 {
            let shares: Vec<String> = behaviours(data)
                .into_iter()
                .map(|b| {
                    let time: f64 = traj
                        .windows(2)
                        .filter(|w| w[0].behaviour.as_deref() == b)
                        .map(|w| w[1].t_s - w[0].t_s)
                        .sum();
                    format!("{} {:.0}%", b.unwrap_or(NONE_LABEL), 100.0 * time / total)
                })
                .collect();
            parts.push(shares.join(", "));
        }
    }
    parts.push(match data.bumps.len() {
        1 => "1 bump".to_owned(),
        n => format!("{n} bumps"),
    });
    let offsets: Vec<f64> = data.offset.iter().map(|p| p.1 - data.targets.offset_m).collect();
    if let Some(rms) = rms(&offsets) {
        parts.push(format!("offset RMS {rms:.3} m"));
    }
    let clearances: Vec<f64> = data.clearance.iter().map(|p| p.1).filter(|v| v.is_finite()).collect();
    let errors: Vec<f64> = clearances.iter().map(|c| c - data.targets.clearance_m).collect();
    if let Some(rms) = rms(&errors) {
        let mean = clearances.iter().sum::<f64>() / clearances.len() as f64;
        parts.push(format!("clearance mean {mean:.3} m, RMS error {rms:.3} m"));
    }
    if let Some(nav) = &data.navigation {
        let reached = nav.goals.iter().filter(|g| g.reached).count();
        parts.push(format!("{reached} of {} goals reached", nav.goals.len()));
        let errors: Vec<f64> = nav.error.iter().map(|p| p.1).collect();
        if let Some(rms) = rms(&errors) {
            parts.push(format!("localization RMS {rms:.3} m"));
        }
    }
    parts.join(" · ")
}

/// The root mean square of the finite values, `None` if there are none.
fn rms(values: &[f64]) -> Option<f64> {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    (!finite.is_empty()).then(|| (finite.iter().map(|v| v * v).sum::<f64>() / finite.len() as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_pick_a_unit() {
        assert_eq!(duration(42.0), "42.0 s");
        assert_eq!(duration(3600.0), "60.0 min");
        assert_eq!(duration(3.0 * 3600.0), "3.00 h");
    }

    #[test]
    fn rms_ignores_non_finite_values() {
        assert_eq!(rms(&[]), None);
        assert_eq!(rms(&[3.0, -3.0, f64::NAN]), Some(3.0));
    }
}
