//! Both searches must equal the brute-force oracle, in 2D and 3D.

use crate::*;
use sph_core::testing::{SplitMix64, random_cloud};
use sph_core::{Dim, Periodic, VectorOps};

fn searches<D: Dim>() -> Vec<(&'static str, AnySearch<D>)> {
    vec![
        ("cell_grid", AnySearch::new(SearchKind::CellGrid)),
        ("kd_tree", AnySearch::new(SearchKind::KdTree)),
    ]
}

/// Asserts that every search gives the brute-force lists for `queries` against `points`.
fn check_against_brute_force<D: Dim>(points: &[D::Vector], queries: &[D::Vector], radius: f64) {
    let mut expect = NeighborList::new();
    brute_force::<D>(points, queries, radius, None, &mut expect);
    for (name, mut s) in searches::<D>() {
        s.build(points, radius).unwrap();
        let mut got = NeighborList::new();
        s.query(queries, &mut got);
        assert_eq!(got.len(), queries.len(), "{name}");
        for i in 0..queries.len() {
            assert_eq!(got.row(i), expect.row(i), "{name} {}: row {i}", D::NAME);
        }
        assert!(got.same_rows(&expect));
    }
}

sph_core::dim_tests! {
    /// Lists queried for a tail of the points, with the head's rows prepended empty, equal the
    /// whole self-join's rows on the tail and are empty on the head.
    fn a_tail_query_with_empty_head_rows_matches_the_self_join<D>() {
        let pts = random_cloud::<D>(900, -1.0, 1.0, 11);
        let r = 0.25;
        for (name, mut s) in searches::<D>() {
            s.build(&pts, r).unwrap();
            let mut all = NeighborList::new();
            s.query(&pts, &mut all);
            let mut tail = NeighborList::new();
            s.query(&pts[600..], &mut tail);
            tail.prepend_empty_rows(600);
            assert_eq!(tail.len(), pts.len(), "{name}");
            for i in 0..pts.len() {
                let expect: &[u32] = if i < 600 { &[] } else { all.row(i) };
                assert_eq!(tail.row(i), expect, "{name} {}: row {i}", D::NAME);
            }
            assert!(all.row(700).len() > 1, "{name}: the tail rows are not trivially empty");
        }
    }

    fn random_clouds_match_brute_force<D>() {
        for (n, seed) in [(10, 1), (1500, 2), (4000, 3)] {
            let pts = random_cloud::<D>(n, -1.0, 1.0, seed);
            // Radius giving ~40 neighbours per point, and a large one giving hundreds.
            let vol_per_pt = 2f64.powi(D::DIM as i32) / n as f64;
            for k in [40.0, 300.0] {
                let r = (k * vol_per_pt).powf(1.0 / D::DIM as f64) * 0.6;
                check_against_brute_force::<D>(&pts, &pts, r);
            }
        }
    }

    fn self_join_contains_self_and_is_sorted<D>() {
        let pts = random_cloud::<D>(800, 0.0, 1.0, 9);
        let mut s = CellGrid::<D>::new();
        s.build(&pts, 0.1).unwrap();
        let mut nl = NeighborList::new();
        s.query(&pts, &mut nl);
        for i in 0..pts.len() {
            let row = nl.row(i);
            assert!(row.binary_search(&(i as u32)).is_ok(), "row {i} lacks itself");
            assert!(row.windows(2).all(|w| w[0] < w[1]), "row {i} not strictly ascending");
        }
    }

    fn probe_points_anywhere<D>() {
        // Queries inside, on the edge of and far outside the indexed cloud.
        let pts = random_cloud::<D>(1000, 0.0, 1.0, 4);
        let mut probes = random_cloud::<D>(300, -0.5, 1.5, 5);
        probes.push(D::Vector::from_fn(|_| 1e9));
        probes.push(D::Vector::from_fn(|_| -1e9));
        check_against_brute_force::<D>(&pts, &probes, 0.12);
    }

    fn empty_and_single_point<D>() {
        check_against_brute_force::<D>(&[], &[], 0.1);
        let empty: Vec<D::Vector> = Vec::new();
        let one = vec![D::Vector::from_fn(|i| 0.25 * i as f64)];
        check_against_brute_force::<D>(&empty, &one, 0.1);
        check_against_brute_force::<D>(&one, &one, 0.1);
        check_against_brute_force::<D>(&one, &empty, 0.1);
    }

    fn coincident_points<D>() {
        // 100 copies of one point, 50 of another at exactly the radius, and a sprinkle.
        let a = D::Vector::from_fn(|_| 0.3);
        let mut b = a;
        b.set(0, 0.3 + 0.05);
        let mut pts = vec![a; 100];
        pts.extend(std::iter::repeat_n(b, 50));
        pts.extend(random_cloud::<D>(100, 0.0, 1.0, 6));
        check_against_brute_force::<D>(&pts, &pts, 0.05);
    }

    fn wide_coordinate_range<D>() {
        // Tight clusters at the origin and at 1e6 plus a sparse scatter over ±1e6: the dense grid
        // would need ~1e14+ cells, so the cell grid must switch to its sparse index.
        let mut pts = random_cloud::<D>(500, -0.01, 0.01, 7);
        pts.extend(random_cloud::<D>(500, 1e6, 1e6 + 0.01, 8));
        pts.extend(random_cloud::<D>(200, -1e6, 1e6, 9));
        check_against_brute_force::<D>(&pts, &pts, 0.002);
        let mut g = CellGrid::<D>::new();
        g.build(&pts, 0.002).unwrap();
        assert!(g.is_sparse());
    }

    fn results_do_not_depend_on_thread_count<D>() {
        let pts = random_cloud::<D>(5000, -1.0, 1.0, 10);
        let run = |threads: usize, kind: SearchKind| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut s = AnySearch::<D>::new(kind);
                s.build(&pts, 0.15).unwrap();
                let mut nl = NeighborList::new();
                s.query(&pts, &mut nl);
                nl
            })
        };
        for kind in [SearchKind::CellGrid, SearchKind::KdTree] {
            let one = run(1, kind);
            for t in [2, 3, 7] {
                assert!(run(t, kind).same_rows(&one), "{kind:?} differs with {t} threads");
            }
        }
    }

    /// The cell grid's query with squared distances gives the plain query's rows, and each
    /// entry's distance is bitwise `(x_q − x_j).length_squared()` — on a randomly numbered
    /// cloud, whose rows leave the cells unsorted (counted below) and are sorted with their
    /// distances — for the self-join and for probe points, on one and three threads, into new
    /// buffers and into buffers kept from the previous query. A
    /// periodic grid and the kd-tree decline (`false`, the distances untouched) and still give
    /// the plain query's rows.
    fn squared_distances_are_those_of_the_entries<D>() {
        let pts = random_cloud::<D>(3000, -1.0, 1.0, 31);
        let probes = random_cloud::<D>(400, -1.2, 1.2, 32);
        let r = 0.2;
        let mut g = CellGrid::<D>::new();
        g.build(&pts, r).unwrap();
        // Rows whose indices do not ascend in the grid's scan order (the cell order).
        let mut slot = vec![0usize; pts.len()];
        for (s, &i) in g.cell_order().iter().enumerate() {
            slot[i as usize] = s;
        }
        // A list and distances kept across the queries (their buffers warm, as the engine's).
        let (mut warm, mut warm_d2) = (NeighborList::new(), Vec::new());
        for queries in [&pts[..], &probes[..], &pts[..]] {
            let mut plain = NeighborList::new();
            g.query(queries, &mut plain);
            let mut unsorted = 0;
            for i in 0..queries.len() {
                let mut scan = plain.row(i).to_vec();
                scan.sort_by_key(|&j| slot[j as usize]);
                unsorted += usize::from(!scan.is_sorted());
            }
            assert!(unsorted > queries.len() / 2, "only {unsorted} rows needed sorting");
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let (mut got, mut d2) = (NeighborList::new(), Vec::new());
                assert!(pool.install(|| g.query_with_squared_distances(queries, &mut got, &mut d2)));
                assert!(got.same_rows(&plain), "{}: rows differ on {threads} threads", D::NAME);
                assert_eq!(d2.len(), got.nnz());
                for i in 0..queries.len() {
                    let row = got.offsets()[i]..got.offsets()[i + 1];
                    for (&j, d) in got.indices()[row.clone()].iter().zip(&d2[row]) {
                        let want = (queries[i] - pts[j as usize]).length_squared();
                        assert_eq!(d.to_bits(), want.to_bits(), "{}: row {i}, entry {j}", D::NAME);
                    }
                }
                assert!(g.query_with_squared_distances(queries, &mut warm, &mut warm_d2));
                assert!(warm.same_rows(&got), "{}: a reused list differs", D::NAME);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&warm_d2), bits(&d2), "{}: reused distances differ", D::NAME);
            }
        }
        let per = Periodic::<D>::new(D::Vector::from_fn(|_| -1.0), D::Vector::from_fn(|_| 1.0), [true, true, D::DIM == 3])
            .unwrap();
        let mut periodic = AnySearch::<D>::new(SearchKind::CellGrid);
        periodic.set_periodic(Some(per));
        let mut kd = AnySearch::<D>::new(SearchKind::KdTree);
        for (name, s, want_periodic) in [("periodic grid", &mut periodic, true), ("kd-tree", &mut kd, false)] {
            s.build(&pts, r).unwrap();
            let (mut got, mut expect, mut d2) = (NeighborList::new(), NeighborList::new(), vec![5.0]);
            assert!(!s.query_with_squared_distances(&pts, &mut got, &mut d2), "{name}");
            assert_eq!(d2, [5.0], "{name}: distances written");
            let oracle = if want_periodic { Some(&per) } else { None };
            brute_force::<D>(&pts, &pts, r, oracle, &mut expect);
            assert!(got.same_rows(&expect), "{name}: rows");
        }
    }

    fn rebuild_reuses_buffers_and_stays_correct<D>() {
        let mut rng = SplitMix64::new(12);
        let mut pts = random_cloud::<D>(2000, 0.0, 1.0, 11);
        let mut s = CellGrid::<D>::new();
        let mut nl = NeighborList::new();
        let mut expect = NeighborList::new();
        for _ in 0..3 {
            for p in pts.iter_mut() {
                *p += rng.vector::<D>(-0.01, 0.01);
            }
            s.build(&pts, 0.08).unwrap();
            s.query(&pts, &mut nl);
            brute_force::<D>(&pts, &pts, 0.08, None, &mut expect);
            assert!(nl.same_rows(&expect));
        }
    }

    fn bad_input_is_an_error<D>() {
        let mut pts = random_cloud::<D>(10, 0.0, 1.0, 13);
        for (_, mut s) in searches::<D>() {
            assert_eq!(s.build(&pts, 0.0), Err(NeighborError::InvalidRadius(0.0)));
            assert_eq!(s.build(&pts, -1.0), Err(NeighborError::InvalidRadius(-1.0)));
            assert!(matches!(s.build(&pts, f64::NAN), Err(NeighborError::InvalidRadius(_))));
        }
        pts[7].set(0, f64::NAN);
        for (_, mut s) in searches::<D>() {
            assert_eq!(s.build(&pts, 0.1), Err(NeighborError::NonFinitePoint { index: 7 }));
        }
        let wide = vec![D::Vector::ZERO, D::Vector::from_fn(|_| 1e300)];
        let mut g = CellGrid::<D>::new();
        assert!(matches!(g.build(&wide, 1e-3), Err(NeighborError::DomainTooWide { .. })));
    }
}

sph_core::dim_tests! {
    /// On lattices whose spacing divides the radius (5 spacings), many pairs lie at the radius
    /// itself, kept or dropped by the last bit of their squared distance (3-4-5 triangles), and
    /// many points on cell edges: both searches find exactly the brute force's rows, for
    /// lattices offset from the origin and for probe points between the lattice points.
    fn lattices_with_pairs_at_the_radius_match_brute_force<D>() {
        for (s, offset) in [(0.1, 0.0), (1.0 / 3.0, 0.0), (0.7, 0.25), (1e-3, 17.0)] {
            let m: usize = if D::DIM == 2 { 24 } else { 11 };
            let mut pts = Vec::new();
            for k in 0..m.pow(D::DIM as u32) {
                let idx = [k % m, (k / m) % m, k / (m * m)];
                pts.push(D::Vector::from_fn(|a| offset + s * idx[a] as f64));
            }
            let r = 5.0 * s;
            let at_radius = pts
                .iter()
                .filter(|x| ((**x - pts[0]).length() / s - 5.0).abs() < 1e-9)
                .count();
            assert!(at_radius >= 3, "{}: {at_radius} points at the radius", D::NAME);
            let probes: Vec<D::Vector> = pts.iter().map(|x| *x + D::Vector::from_fn(|_| 0.5 * s)).collect();
            check_against_brute_force::<D>(&pts, &pts, r);
            check_against_brute_force::<D>(&pts, &probes, r);
        }
    }
}

sph_core::dim_tests! {
    /// Periodic search equals the minimum-image brute force, for both backends, with points
    /// crowding the periodic faces and corners; rows hold no duplicates.
    fn periodic_search_matches_minimum_image_brute_force<D>() {
        let hi = D::Vector::from_fn(|k| [1.0, 0.7, 0.9][k]);
        let axes = [true, D::DIM == 2, D::DIM == 3];
        let per = Periodic::<D>::new(D::Vector::ZERO, hi, axes).unwrap();
        let mut pts: Vec<D::Vector> = random_cloud::<D>(2500, 0.0, 1.0, 21)
            .into_iter()
            .map(|x| per.wrap(D::Vector::from_fn(|k| x.get(k) * hi.get(k))))
            .collect();
        // Points on and next to the faces.
        pts.push(D::Vector::ZERO);
        pts.push(per.wrap(D::Vector::from_fn(|k| if k == 0 { hi.get(0) - 1e-12 } else { 0.0 })));
        let r = 0.12;
        let mut expect = NeighborList::new();
        brute_force::<D>(&pts, &pts, r, Some(&per), &mut expect);
        for (name, mut s) in searches::<D>() {
            s.set_periodic(Some(per));
            s.build(&pts, r).unwrap();
            let mut got = NeighborList::new();
            s.query(&pts, &mut got);
            for i in 0..pts.len() {
                assert_eq!(got.row(i), expect.row(i), "{name} {}: row {i}", D::NAME);
                assert!(got.row(i).windows(2).all(|w| w[0] < w[1]));
            }
        }
        // Across the x face: the point at the origin sees the one just below x = 1.
        let (a, b) = (pts.len() as u32 - 2, pts.len() as u32 - 1);
        assert!(expect.row(a as usize).contains(&b));
    }

    fn periodic_search_refuses_a_short_period_or_a_point_outside<D>() {
        let per = Periodic::<D>::new(
            D::Vector::ZERO,
            D::Vector::from_fn(|_| 1.0),
            [true, false, false],
        )
        .unwrap();
        for (_, mut s) in searches::<D>() {
            s.set_periodic(Some(per));
            let inside = vec![D::Vector::from_fn(|_| 0.5)];
            assert!(matches!(s.build(&inside, 0.5), Err(NeighborError::Periodic(_))));
            let outside = vec![D::Vector::from_fn(|k| if k == 0 { 1.0 } else { 0.5 })];
            assert!(matches!(s.build(&outside, 0.1), Err(NeighborError::Periodic(_))));
            assert!(s.build(&inside, 0.1).is_ok());
        }
    }
}
