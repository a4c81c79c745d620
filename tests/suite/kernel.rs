//! Kernel normalisation: each kernel integrates to one over the unit disc (2-D) and ball (3-D).

use haze::estimate::kernel::Kernel;
use std::f64::consts::PI;

#[test]
fn kernels_integrate_to_one() {
    let n = 100_000;
    for k in Kernel::ALL {
        // Radial quadrature (midpoint rule): ∫ K(u) · (2πu | 4πu²) du over [0, 1].
        let (mut two, mut three) = (0.0f64, 0.0f64);
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            let du = 1.0 / n as f64;
            two += k.eval((u * u) as f32, 2) as f64 * 2.0 * PI * u * du;
            three += k.eval((u * u) as f32, 3) as f64 * 4.0 * PI * u * u * du;
        }
        assert!((two - 1.0).abs() < 1e-5, "{k:?} 2-D integrates to {two}");
        assert!((three - 1.0).abs() < 1e-5, "{k:?} 3-D integrates to {three}");
        assert_eq!(k.eval(1.0, 2), 0.0);
        assert_eq!(k.eval(1.5, 3), 0.0);
        assert_eq!(k.name().parse::<Kernel>(), Ok(*k));
    }
    assert!("gaussian".parse::<Kernel>().is_err());
}
