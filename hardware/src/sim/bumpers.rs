//! The bumper ring: which bumpers are pressed, and how many times contact began.
//!
//! Bumpers are fixed to the base. A synchro-drive robot's base never rotates (only the wheels
//! steer and the turret turns), so bumper angles are relative to the base's orientation at
//! start-up, whatever the heading now. Anything closer than the contact margin to the body's
//! edge presses, in each of the two rings, the bumper whose sector contains the direction of
//! its closest point. The lower ring's bumper `k` covers `k x 36 ± 18` degrees, the upper
//! ring's (ids 10 + k) `k x 36 + 18 ± 18` degrees.

use orsa_actors::Timestamp;
use orsa_interfaces::nomad200::{BUMPER_COUNT, ContactScan};
use std::f64::consts::TAU;

/// The two bumpers (one per ring) whose sectors contain `angle_rad` (relative to the base).
pub(crate) fn bumpers_at(angle_rad: f64) -> [usize; 2] {
    let per_ring = BUMPER_COUNT / 2;
    let sector = TAU / per_ring as f64;
    let a = angle_rad.rem_euclid(TAU);
    let lower = ((a + sector / 2.0) / sector).floor() as usize % per_ring;
    let upper = per_ring + (a / sector).floor() as usize % per_ring;
    [lower, upper]
}

/// The ring's state.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Bumpers {
    pressed: [bool; BUMPER_COUNT],
    stamp_ns: u64,
    onsets: u64,
}

impl Bumpers {
    pub(crate) fn new() -> Self {
        Bumpers { pressed: [false; BUMPER_COUNT], stamp_ns: 0, onsets: 0 }
    }

    /// The state at `now_ns`, given the directions (relative to the base) of every contact.
    pub(crate) fn update(&mut self, now_ns: u64, contacts: impl IntoIterator<Item = f64>) {
        let was = self.in_contact();
        self.pressed = [false; BUMPER_COUNT];
        for angle in contacts {
            for b in bumpers_at(angle) {
                self.pressed[b] = true;
            }
        }
        if self.in_contact() && !was {
            self.onsets += 1;
        }
        self.stamp_ns = now_ns;
    }

    pub(crate) fn in_contact(&self) -> bool {
        self.pressed.iter().any(|&p| p)
    }

    /// How many times contact began (no bumper pressed, then some).
    pub(crate) fn onsets(&self) -> u64 {
        self.onsets
    }

    pub(crate) fn scan(&self, origin: Timestamp) -> ContactScan {
        ContactScan {
            stamp: Timestamp(origin.0.saturating_add(self.stamp_ns)),
            pressed: self.pressed.to_vec(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use orsa_interfaces::nomad200::bumper_angle_rad;

    #[test]
    fn each_bumper_centre_maps_to_itself() {
        for i in 0..BUMPER_COUNT {
            assert!(bumpers_at(bumper_angle_rad(i)).contains(&i), "bumper {i}");
        }
    }

    #[test]
    fn sectors_split_at_half_spacing() {
        let deg = |d: f64| d.to_radians();
        assert_eq!(bumpers_at(deg(0.0)), [0, 10]);
        assert_eq!(bumpers_at(deg(17.9)), [0, 10]);
        assert_eq!(bumpers_at(deg(18.1)), [1, 10]);
        assert_eq!(bumpers_at(deg(-1.0)), [0, 19]);
        assert_eq!(bumpers_at(deg(80.0)), [2, 12], "left-front");
        assert_eq!(bumpers_at(deg(-80.0)), [8, 17], "right-front");
    }

    #[test]
    fn onsets_count_rising_edges_only() {
        let mut b = Bumpers::new();
        b.update(1, []);
        b.update(2, [0.0]);
        b.update(3, [0.0, 1.0]);
        b.update(4, []);
        b.update(5, [3.0]);
        assert_eq!(b.onsets(), 2);
        assert!(b.in_contact());
        assert_eq!(b.scan(Timestamp(10)).stamp, Timestamp(15));
    }
}
