//! Unit tests of the simulation's set-up checks (src/sim/mod.rs).
use super::{reference, Params};

/// `[sim] wall_friction` outside 0..=10 (or not a number) is a settings error naming the key.
#[test]
fn wall_friction_out_of_range_is_an_error() {
    for bad in [-1.0, 10.5, f32::NAN, f32::INFINITY] {
        let e = Params { wall_friction: bad, ..Params::default() }.validate().unwrap_err().to_string();
        assert!(e.contains("wall_friction"), "{bad}: {e}");
    }
    for good in [0.0, 1.0, 10.0] {
        Params { wall_friction: good, ..Params::default() }.validate().unwrap();
    }
}

/// `[sim] scorr_n` is a whole number 1..=15 (the shader's powers by squaring); a fraction is a parse error.
#[test]
fn scorr_n_out_of_range_is_an_error() {
    for bad in [0, 16] {
        let e = Params { scorr_n: bad, ..Params::default() }.validate().unwrap_err().to_string();
        assert!(e.contains("scorr_n"), "{bad}: {e}");
    }
    for good in [1, 4, 15] {
        Params { scorr_n: good, ..Params::default() }.validate().unwrap();
    }
    assert!(toml::from_str::<Params>("scorr_n = 4.5").is_err());
}

/// The CPU reference's s_corr power (the shader's, product for product) is xⁿ for every allowed n, and
/// exactly (x·x)·(x·x) for the default n = 4.
#[test]
fn scorr_power_by_squaring() {
    for n in 1..=15u32 {
        for x in [0.0f32, 0.3, 0.77, 1.0, 1.9] {
            let p = reference::scorr_pow_n(n, x);
            let want = x.powi(n as i32);
            assert!((p - want).abs() <= 1e-6 * want.abs().max(1e-30), "{x}^{n}: {p} vs {want}");
        }
    }
    assert_eq!(reference::scorr_pow_n(4, 0.77), (0.77f32 * 0.77) * (0.77 * 0.77));
}
