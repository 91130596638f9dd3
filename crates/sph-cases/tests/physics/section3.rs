//! Paper Section 3: the volume-loss slopes of the Euler and predictor–corrector position updates
//! under a prescribed divergence-free linear field, against the exact `ln det F / Δt`.

use sph_cases::geometry::ellipsoid_lattice;
use sph_cases::prescribed::{PositionUpdate, paper_setup, run_prescribed};
use sph_cases::reference::References;
use sph_core::{D2, D3, Dim};

fn check<D: Dim>(table_case: &str) {
    let (semi, g) = paper_setup::<D>();
    let dt = 1.25e-4;
    for update in [PositionUpdate::Euler, PositionUpdate::PredictorCorrector] {
        let pts = ellipsoid_lattice::<D>(semi, 0.05);
        let run = run_prescribed::<D>(pts, g, dt, 24, update);
        let table = References::embedded()
            .volume_slope(table_case, update.name(), dt)
            .unwrap();
        println!(
            "{} {:?}: hull {:.9e}, moments {:.9e}, exact {:.9e}, table {table:.9e}",
            D::NAME,
            update,
            run.slope_hull,
            run.slope_moments,
            run.exact_slope
        );
        // The bar is 0.5 %; both measures reproduce the exact slope far more closely.
        for measured in [run.slope_hull, run.slope_moments] {
            assert!(
                (measured / run.exact_slope - 1.0).abs() < 0.005,
                "{update:?}: {measured} vs {}",
                run.exact_slope
            );
        }
        assert!(
            (run.exact_slope / table - 1.0).abs() < 1e-8,
            "exact {} vs table {table}",
            run.exact_slope
        );
    }
}

#[test]
fn section3_slopes_2d() {
    // Euler −1.2501 (paper: −1.25), PC +4.883e-5 (paper: 4.88e-5).
    check::<D2>("2d_sec3");
}

#[test]
fn section3_slopes_3d() {
    // Euler −0.93365 (paper: −0.93), PC −1.926e-3: a volume *loss*; the paper prints 1.92e-3
    // without a sign.
    check::<D3>("3d_sec3");
}
