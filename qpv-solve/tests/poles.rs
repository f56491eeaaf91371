//! Pole regions (`poles = ...`, docs/method.md §18): each region imposed
//! with the design's P and certified as family D, checked here by brute
//! force on the eigenvalues of the frozen vertex dynamics A_l − L_l C_l;
//! the certificate rejects gains that leave a region; a disk bounds the
//! gains of the three-tank LPV plant.

use nalgebra::DMatrix;
use qpv_dsl::{AlphaSpec, DesignRequest, GammaSpec, Mode, PoleRegion, PolytopicModel};
use qpv_solve::certificate::poles::disk_gain_bound;
use qpv_solve::certificate::{check, Gains};
use qpv_solve::vocab::Candidate;
use qpv_solve::{design, Design, Settings};

fn three_tank() -> PolytopicModel {
    qpv_dsl::parse(include_str!("../../examples/three_tank.qpv")).expect("parses")[0].polytopic()
}

fn paper() -> PolytopicModel {
    qpv_solve::conditions::reference::paper_model()
}

fn run(m: &PolytopicModel, alpha: AlphaSpec, gamma: GammaSpec, poles: &[PoleRegion]) -> Design {
    let r = DesignRequest {
        poles: poles.to_vec(),
        ..qpv_solve::request(alpha, gamma, Mode::Sound)
    };
    design(m, &r, &Settings::default()).expect("design runs")
}

/// The eigenvalues (re, im) of A_l − L_l C_l at every θ-vertex l.
fn vertex_eigs(m: &PolytopicModel, l: &[DMatrix<f64>]) -> Vec<Vec<(f64, f64)>> {
    m.vertices
        .iter()
        .zip(l)
        .map(|(v, li)| {
            let f = &v.a - li * &v.c;
            f.complex_eigenvalues()
                .iter()
                .map(|z| (z.re, z.im))
                .collect()
        })
        .collect()
}

/// Every frozen vertex eigenvalue lies in every region (brute force).
fn assert_in_regions(m: &PolytopicModel, d: &Design, poles: &[PoleRegion]) {
    for (l, eigs) in vertex_eigs(m, &d.l_matrices()).iter().enumerate() {
        for &(re, im) in eigs {
            for r in poles {
                assert!(
                    r.contains(re, im),
                    "vertex {}: λ = {re} + {im}i outside {r}",
                    l + 1
                );
            }
        }
    }
}

fn max_gain(d: &Design) -> f64 {
    d.gain_norms.iter().copied().fold(0.0, f64::max)
}

#[test]
fn each_region_holds_on_the_frozen_vertex_eigenvalues_of_the_lpv_plant() {
    let m = three_tank();
    let regions = [
        vec![PoleRegion::Disk {
            centre: -3.0,
            radius: 3.0,
        }],
        vec![PoleRegion::Sector { angle: 30.0 }],
        vec![PoleRegion::Strip {
            lo: -4.0,
            hi: -0.02,
        }],
        vec![
            PoleRegion::Disk {
                centre: -2.0,
                radius: 2.0,
            },
            PoleRegion::Sector { angle: 45.0 },
        ],
    ];
    for poles in &regions {
        let d = run(&m, AlphaSpec::Fixed(0.05), GammaSpec::Search, poles);
        assert!(d.certifies(), "{poles:?}: {}", d.summary);
        assert!(d.margins.contains_key("D"), "{:?}", d.margins);
        assert_eq!(&d.poles, poles);
        assert!(d.summary.contains("pole regions"), "{}", d.summary);
        assert_in_regions(&m, &d, poles);
        // The report re-checks with its poles.
        let cert = d.recheck_on(&m);
        assert!(cert.passed, "{poles:?}: {:?}", cert.families);
        assert!(cert.family("D").is_some_and(|f| f.passed && f.count > 0));
    }
}

#[test]
fn each_region_holds_on_the_frozen_vertex_eigenvalues_of_a_qpv_plant() {
    let m = paper();
    let regions = [
        vec![PoleRegion::Disk {
            centre: -15.0,
            radius: 14.0,
        }],
        vec![PoleRegion::Sector { angle: 60.0 }],
        vec![PoleRegion::Strip {
            lo: -40.0,
            hi: -1.0,
        }],
    ];
    for poles in &regions {
        let d = run(&m, AlphaSpec::Fixed(2.0), GammaSpec::Fixed(0.15), poles);
        assert!(d.certifies(), "{poles:?}: {}", d.summary);
        let fam = d.recheck_on(&m);
        let dfam = fam.family("D").expect("family D");
        // Every θ-vertex, every region-vertex pair.
        assert_eq!(dfam.count % 8, 0, "{dfam:?}");
        assert!(dfam.count > 8, "{dfam:?}");
        assert_in_regions(&m, &d, poles);
    }
}

#[test]
fn the_certificate_rejects_gains_that_leave_a_region() {
    let m = three_tank();
    let disk = [PoleRegion::Disk {
        centre: -3.0,
        radius: 3.0,
    }];
    let d = run(&m, AlphaSpec::Fixed(0.09), GammaSpec::Search, &disk);
    assert!(d.certifies(), "{}", d.summary);
    let (p, l) = (d.p_matrix(), d.l_matrices());
    let at = Candidate::new(d.alpha, d.gamma);
    let cert = |l: &[DMatrix<f64>], poles: &[PoleRegion]| {
        let g = Gains::new(&p, l);
        check(&m, &g, &at, Mode::Sound).with_poles(&m, &g, &at, poles)
    };
    assert!(cert(&l, &disk).passed);
    // Tampered: vertex 6's gain on x3 raised by 20, which moves its x3
    // mode to about −20, outside the disk (−6, 0).
    let mut bad = l.clone();
    bad[5][(2, 0)] += 20.0;
    let eigs = vertex_eigs(&m, &bad);
    assert!(
        eigs[5].iter().any(|&(re, im)| !disk[0].contains(re, im)),
        "the tampered gain must leave the disk: {:?}",
        eigs[5]
    );
    let c = cert(&bad, &disk);
    assert!(!c.passed);
    let f = c.family("D").expect("family D");
    assert!(!f.passed && f.worst_at.contains("l=6"), "{f:?}");
    // Regions the design was not made for: the same gains fail a disk that
    // excludes the plant's slowest mode (−0.05 at vertex 1), a sector
    // narrower than its complex pairs, a strip left of that mode.
    let untouched = cert(&l, &[]);
    assert!(untouched.passed && untouched.family("D").is_none());
    for region in [
        PoleRegion::Disk {
            centre: -2.0,
            radius: 1.0,
        },
        PoleRegion::Strip { lo: -9.0, hi: -1.0 },
    ] {
        let c = cert(&l, &[region]);
        assert!(!c.passed, "{region}");
        assert!(c.family("G5").is_some_and(|f| f.passed));
        assert!(c.family("D").is_some_and(|f| !f.passed));
    }
}

#[test]
fn a_disk_bounds_the_gains_of_the_three_tank() {
    let m = three_tank();
    let free = run(&m, AlphaSpec::Max, GammaSpec::Search, &[]);
    let disk = [PoleRegion::Disk {
        centre: -30.0,
        radius: 30.0,
    }];
    let bounded = run(&m, AlphaSpec::Max, GammaSpec::Search, &disk);
    assert!(free.certifies() && bounded.certifies());
    let (g0, g1) = (max_gain(&free), max_gain(&bounded));
    println!(
        "three-tank alpha = max: α = {:.4}, max ‖L_l‖₂ = {g0:.4e} without a disk; α = {:.4}, {g1:.4e} with {}",
        free.alpha, bounded.alpha, disk[0]
    );
    // The bound the disk implies holds, is reported, and recomputes.
    let b = bounded
        .pole_gain_bound
        .expect("a disk on an LPV plant reports its bound");
    assert_eq!(Some(b), disk_gain_bound(&m, &bounded.p_matrix(), &disk));
    assert!(g1 <= b, "{g1} > bound {b}");
    assert_in_regions(&m, &bounded, &disk);
    // Without the disk α = max buys its rate with gains the disk forbids.
    assert!(g0 > 1e3 * g1, "{g0} vs {g1}");
    assert!(free.pole_gain_bound.is_none() && free.poles.is_empty());
}

#[test]
fn a_qpv_design_reports_what_its_region_costs() {
    let m = paper();
    let settings = Settings {
        region_cost: true,
        ..Settings::default()
    };
    let req = qpv_solve::request(AlphaSpec::Fixed(2.0), GammaSpec::Fixed(0.15), Mode::Sound);
    // Off by default: no figure, no extra searches.
    assert!(run(&m, AlphaSpec::Fixed(2.0), GammaSpec::Fixed(0.15), &[])
        .linear_part_alpha
        .is_none());
    let d = design(&m, &req, &settings).expect("runs");
    assert!(d.certifies(), "{}", d.summary);
    assert!(d.linear_part_alpha_at_gain.is_some());
    let lin = d
        .linear_part_alpha
        .expect("a certified QPV design reports its linear part's α");
    // The region contains the origin: the QPV (P, L) satisfy the global
    // conditions of the linear part at the same α (1 % search tolerance).
    assert!(lin >= 0.99 * d.alpha, "{lin} < {}", d.alpha);
    assert!(d
        .notes
        .iter()
        .any(|n| n.to_string().contains("region cost")));
    // Recomputed independently: the linear part as an LPV model certifies
    // the QPV design's own α globally (lin ≥ α is about that).
    let lp = qpv_solve::search::region_cost::linear_part(&m);
    assert!(lp.is_lpv());
    let r = qpv_solve::request(AlphaSpec::Fixed(d.alpha), GammaSpec::Search, Mode::Sound);
    let g = design(&lp, &r, &Settings::default()).expect("runs");
    assert!(g.certifies() && g.global, "{}", g.summary);
    // Not for LPV plants (no region to cost) nor uncertified designs.
    let r = qpv_solve::request(AlphaSpec::Fixed(0.09), GammaSpec::Search, Mode::Sound);
    let t = design(&three_tank(), &r, &settings).expect("runs");
    assert!(t.certifies() && t.linear_part_alpha.is_none());
}
