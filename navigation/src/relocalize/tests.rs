//! Relocalization on the synthetic room of [`crate::mcl`]'s tests: a robot carried elsewhere is
//! noticed, and found again from one turn on the spot.

use super::*;
use crate::mcl::tests::{read, room};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn setup() -> (DistanceField, Relocalizer) {
    let g = room();
    let field = DistanceField::of(&g, 1.0);
    let r = Relocalizer::new(RelocParams::default(), &field, [0.0, 0.0, 10.0, 6.0], 0.25);
    (field, r)
}

/// Turns the robot a full turn at `truth` (odometry starting at `odom`), an update every 10
/// degrees, gathering what it reads; returns the odometry pose at the end.
fn turn(
    r: &mut Relocalizer,
    g: &orsa_interfaces::map::OccupancyGrid,
    truth: Pose2,
    odom: Pose2,
    seed: u64,
) -> Pose2 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut o = odom;
    for k in 0..36 {
        let d = f64::from(k) * 10f64.to_radians();
        let t = Pose2::new(truth.x, truth.y, wrap(truth.theta + d));
        o = Pose2::new(odom.x, odom.y, wrap(odom.theta + d));
        r.gather(o, &read(g, t, &mut rng));
    }
    o
}

#[test]
fn the_estimate_agrees_where_the_robot_is_and_a_kidnapping_is_noticed() {
    let g = room();
    let (field, mut r) = setup();
    let truth = Pose2::new(2.5, 3.0, 0.3);
    // Odometry starts at zero: map -> odom is the start pose.
    let odom = turn(&mut r, &g, truth, Pose2::default(), 1);
    let share = r.judge(&field, truth).expect("enough echoes");
    assert!(share > 0.9, "agreement at the truth {share}");
    assert!(!r.lost());
    // Carried to the other end of the room: odometry does not see it, the estimate stays.
    turn(&mut r, &g, Pose2::new(8.0, 4.5, -2.0), odom, 2);
    let share = r.judge(&field, truth).expect("enough echoes");
    assert!(share < RelocParams::default().lost_below, "agreement after a kidnapping {share}");
    assert!(r.lost());
}

#[test]
fn a_lost_robot_is_found_from_one_turn_on_the_spot_on_several_seeds() {
    let g = room();
    let places = [
        Pose2::new(8.0, 4.5, -2.0),
        Pose2::new(2.0, 1.5, 1.0),
        Pose2::new(5.5, 4.0, 3.0),
        Pose2::new(9.0, 1.0, 0.0),
        Pose2::new(3.0, 3.5, -0.7),
    ];
    for (i, &truth) in places.iter().enumerate() {
        let seed = i as u64 + 1;
        let (field, mut r) = setup();
        r.set_lost();
        let odom = Pose2::new(-3.0, 7.0, 0.4);
        let end = turn(&mut r, &g, truth, odom, seed);
        assert!(r.search_due(), "seed {seed}: a full turn is enough to search");
        let now = Pose2::new(truth.x, truth.y, wrap(truth.theta + wrap(end.theta - odom.theta)));
        match r.search(&field, end).expect("a search") {
            Search::Found(f) => {
                let off = (f.pose.x - now.x).hypot(f.pose.y - now.y);
                let turned = wrap(f.pose.theta - now.theta).abs().to_degrees();
                assert!(off < 0.15 && turned < 5.0, "seed {seed}: found {f:?}, truly {now:?}");
                assert!(!r.lost());
            }
            other => panic!("seed {seed}: {other:?}, truly {now:?}"),
        }
    }
}

/// An empty square room, 6 m a side: every corner looks the same turned by 90 degrees.
fn square() -> (orsa_interfaces::map::OccupancyGrid, DistanceField) {
    let mut g =
        orsa_interfaces::map::OccupancyGrid::filled(0.05, 124, 124, (-0.1, -0.1), orsa_interfaces::map::FREE);
    for iy in 0..g.height {
        for ix in 0..g.width {
            let (x, y) = g.centre(ix, iy);
            if !(0.0..=6.0).contains(&x) || !(0.0..=6.0).contains(&y) {
                let i = g.index(ix, iy);
                g.cells[i] = orsa_interfaces::map::OCCUPIED;
            }
        }
    }
    let field = DistanceField::of(&g, 1.0);
    (g, field)
}

/// The pose now of a robot whose map -> odom is `map_odom`, at odometry pose `odom`.
fn on(map_odom: Pose2, odom: Pose2) -> Pose2 {
    let (x, y) = map_odom.apply(odom.x, odom.y);
    Pose2::new(x, y, wrap(map_odom.theta + odom.theta))
}

#[test]
fn where_places_look_alike_the_track_before_the_loss_breaks_the_tie() {
    // Each corner of the square, the robot judged lost there (people's echoes, say) while its
    // estimate was right, or 0.3 m and 4 degrees off: the search finds every corner alike, and
    // keeps the one it was tracked at, at the truth.
    let (g, field) = square();
    let corners = [(1.5, 1.5, 0.0), (4.5, 1.5, 1.9), (4.5, 4.5, -2.8), (1.5, 4.5, 0.7)];
    for (i, &(x, y, theta)) in corners.iter().enumerate() {
        for off in [0.0, 0.3] {
            let mut r = Relocalizer::new(RelocParams::default(), &field, [0.0, 0.0, 6.0, 6.0], 0.25);
            let truth = Pose2::new(x, y, theta);
            // Odometry starts at zero, so map -> odom is the start pose.
            let estimate = Pose2::new(x + off, y - off, theta + off.to_radians() * 13.0);
            r.set_lost_from(estimate);
            let end = turn(&mut r, &g, truth, Pose2::default(), i as u64 + 10);
            let now = on(truth, end);
            match r.search(&field, end).expect("a search") {
                Search::Kept(f) => {
                    let miss = (f.pose.x - now.x).hypot(f.pose.y - now.y);
                    let turned = wrap(f.pose.theta - now.theta).abs().to_degrees();
                    assert!(miss < 0.15 && turned < 5.0, "corner {i}, off {off}: kept {f:?}, truly {now:?}");
                    assert!(!r.lost() && !r.guessing());
                }
                other => panic!("corner {i}, off {off}: {other:?}, truly {now:?}"),
            }
        }
    }
}

#[test]
fn a_track_that_does_not_fit_decides_nothing() {
    // Kidnapped: tracked at one place, carried to another. Where it was tracked fits badly, so
    // the search finds it where it is, as without a track.
    let g = room();
    let (field, mut r) = setup();
    let truth = Pose2::new(8.0, 4.5, -2.0);
    r.set_lost_from(Pose2::new(2.5, 3.0, 0.3));
    let end = turn(&mut r, &g, truth, Pose2::default(), 7);
    let now = on(truth, end);
    match r.search(&field, end).expect("a search") {
        Search::Found(f) => {
            assert!((f.pose.x - now.x).hypot(f.pose.y - now.y) < 0.15, "{f:?}, truly {now:?}")
        }
        other => panic!("{other:?}, truly {now:?}"),
    }
    // And in the square, a track at the room's middle (no corner) leaves the corners a guess.
    let (g, field) = square();
    let mut r = Relocalizer::new(RelocParams::default(), &field, [0.0, 0.0, 6.0, 6.0], 0.25);
    r.set_lost_from(Pose2::new(3.0, 3.0, 0.0));
    let end = turn(&mut r, &g, Pose2::new(1.5, 1.5, 0.0), Pose2::default(), 3);
    assert!(matches!(r.search(&field, end), Some(Search::Guess(..))), "a guess, as without a track");
}

#[test]
fn where_two_places_look_alike_the_best_is_a_guess_until_moving_tells_them_apart() {
    let (g, field) = square();
    let mut r = Relocalizer::new(RelocParams::default(), &field, [0.0, 0.0, 6.0, 6.0], 0.25);
    r.set_lost();
    let truth = Pose2::new(1.5, 1.5, 0.0);
    let end = turn(&mut r, &g, truth, Pose2::default(), 3);
    let (best, rival) = match r.search(&field, end).expect("a search") {
        Search::Guess(best, rival) => (best, rival),
        other => panic!("a symmetric room cannot tell its corners apart: {other:?}"),
    };
    assert!(1.0 - rival.score < 2.0 * (1.0 - best.score), "{best:?} {rival:?}");
    assert!(!r.lost() && r.guessing(), "placed at the guess, not confirmed");
    // Whichever corner it guessed, the estimate fits as long as the robot turns there...
    let map_odom = |guess: Pose2| {
        // The guess is the pose now (odometry `end`): map -> odom = guess * end^-1.
        let theta = wrap(guess.theta - end.theta);
        let (s, c) = theta.sin_cos();
        Pose2::new(guess.x - (c * end.x - s * end.y), guess.y - (s * end.x + c * end.y), theta)
    };
    let share = r.judge(&field, map_odom(best.pose)).expect("enough echoes");
    assert!(share > 0.9, "{share}");
    assert!(r.guessing());
    // (A copy that goes on turning there for a whole window takes the guess as found.)
    let mut held = r.clone();
    for _ in 0..RelocParams::default().gather_max {
        held.gather(end, &[]);
    }
    assert!(!held.lost() && !held.guessing() && !held.search_due(), "a guess that held is found");
    // ... and a guess that stops fitting (as if it drove off and saw the other corner's
    // walls elsewhere) is lost again, keeping what it gathered.
    let wrong = Pose2::new(best.pose.x + 2.0, best.pose.y + 1.0, best.pose.theta + 0.5);
    let share = r.judge(&field, map_odom(wrong)).expect("enough echoes");
    assert!(share < RelocParams::default().lost_below, "{share}");
    assert!(r.lost() && !r.guessing());
    assert!(r.search_due() || r.echoes.len() > 300, "what was gathered is kept: {}", r.echoes.len());
}
