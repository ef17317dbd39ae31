//! Newtonian and HMM generators: finite, in range, reproducible from a seed.

use gpecnet_trainer::rng::Rng;
use gpecnet_trainer::synth::hmm::{n_ics, simulate, Attributes, TRANSITIONS};
use gpecnet_trainer::synth::newtonian::{generate, Kind, Motion};
use gpecnet_trainer::synth::{in_range, DT};

#[test]
fn newtonian_is_finite_in_range_and_reproducible() {
    for kind in [Kind::ConstVel, Kind::ConstAcc, Kind::Turn] {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        let mut c = Rng::new(8);
        for _ in 0..500 {
            let ta = generate(kind, &mut a);
            assert!(in_range(&ta), "{kind:?}: {ta:?}");
            assert_eq!(ta, generate(kind, &mut b));
        }
        assert_ne!(generate(kind, &mut a), generate(kind, &mut c));
    }
}

#[test]
fn newtonian_kinematics() {
    let cv = Motion::ConstVel { v: [10.0, 0.0] }.integrate();
    assert_eq!(cv[0], [0.0, 0.0]);
    assert!((cv[19][0] - 10.0 * 19.0 * DT).abs() < 1e-3);
    let ca = Motion::ConstAcc {
        v: [0.0, 0.0],
        a: [0.0, 2.0],
    }
    .integrate();
    let t = 19.0 * DT;
    assert!((ca[19][1] - t * t).abs() < 1e-3);
    // A turn keeps a constant step length.
    let tr = Motion::Turn {
        speed: 50.0,
        heading: 0.3,
        omega: 0.5,
    }
    .integrate();
    for w in tr.windows(2) {
        let l = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        assert!((l - 50.0 * DT).abs() < 1e-3);
    }
}

#[test]
fn hmm_transitions_are_stochastic() {
    for row in TRANSITIONS {
        assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        assert!(row.iter().all(|&p| p >= 0.0));
    }
    let mut rng = Rng::new(3);
    for _ in 0..100 {
        let a = Attributes::random(&mut rng);
        for v in [a.fitness, a.patience, a.sociability] {
            assert!((0.0..=1.0).contains(&v));
        }
    }
}

#[test]
fn proximity_counts_agents_inside_the_circle() {
    let others = [[0.0, 0.0], [3.0, 4.0], [10.0, 0.0], [0.0, -4.9]];
    assert_eq!(n_ics([0.0, 0.0], &others, 5.0), 2); // (0,0) and (0,-4.9); (3,4) is at 5, not < 5
    assert_eq!(n_ics([0.0, 0.0], &others, 5.01), 3);
    assert_eq!(n_ics([100.0, 100.0], &others, 5.0), 0);
}

#[test]
fn hmm_simulation_is_finite_and_reproducible() {
    let (a, na) = simulate(8, 400.0, &mut Rng::new(11));
    let (b, nb) = simulate(8, 400.0, &mut Rng::new(11));
    assert_eq!(a, b);
    assert_eq!(na, nb);
    assert_eq!(a.len(), 8);
    for t in &a {
        assert!(t.iter().all(|p| p[0].is_finite()
            && (0.0..=400.0).contains(&p[0])
            && (0.0..=400.0).contains(&p[1])));
    }
    // A crowded playground has impending collision states.
    let (_, n) = simulate(30, 150.0, &mut Rng::new(1));
    assert!(n > 0);
}
