//! The KKT solver setting: QDLDL by default, and (feature `faer`) faer's
//! supernodal LDLᵀ giving the same certified designs.

use qpv_solve::backend::clarabel_settings;
use qpv_solve::{KktSolver, Settings};

#[test]
fn the_default_kkt_solver_reaches_clarabel() {
    let s = Settings::default();
    let cs = clarabel_settings(&s);
    #[cfg(not(feature = "faer"))]
    {
        assert_eq!(s.kkt_solver, KktSolver::Qdldl);
        assert_eq!(cs.direct_solve_method, "qdldl");
    }
    #[cfg(feature = "faer")]
    {
        assert_eq!(s.kkt_solver, KktSolver::Auto);
        assert_eq!(cs.direct_solve_method, "auto");
        let f = clarabel_settings(&Settings {
            kkt_solver: KktSolver::Faer { threads: 1 },
            ..s
        });
        assert_eq!((f.direct_solve_method.as_str(), f.max_threads), ("faer", 1));
    }
    let q = clarabel_settings(&Settings {
        kkt_solver: KktSolver::Qdldl,
        ..Settings::default()
    });
    assert_eq!(q.direct_solve_method, "qdldl");
}

#[cfg(feature = "faer")]
mod faer {
    use qpv_dsl::{AlphaSpec, Conditions, GammaSpec, Mode};
    use qpv_solve::conditions::reference::{paper_model, synthetic_model};
    use qpv_solve::{design, request, Design, KktSolver, Settings};

    fn run(model: &qpv_dsl::PolytopicModel, alpha: AlphaSpec, gamma: f64, k: KktSolver) -> Design {
        let mut req = request(alpha, GammaSpec::Fixed(gamma), Mode::Sound);
        req.conditions = Conditions::Cube;
        // α = max is the certified supremum, not the practical point within
        // 1 % of it (the default `within`).
        req.within = 0.0;
        let settings = Settings {
            kkt_solver: k,
            ..Settings::default()
        };
        design(model, &req, &settings).expect("the design runs")
    }

    #[test]
    fn faer_and_qdldl_find_the_same_cube_alpha_on_the_paper_example() {
        let model = paper_model();
        let q = run(&model, AlphaSpec::Max, 0.18898, KktSolver::Qdldl);
        assert!(q.feasible() && q.certifies(), "{}", q.summary);
        for k in [
            KktSolver::Faer { threads: 1 },
            KktSolver::Faer { threads: 2 },
        ] {
            let f = run(&model, AlphaSpec::Max, 0.18898, k);
            assert!(f.feasible() && f.certifies(), "{k:?}: {}", f.summary);
            assert!(f.recheck(&model).passed, "{k:?}");
            // the bisection's relative tolerance is 1e-3
            let rel = (f.alpha - q.alpha).abs() / q.alpha;
            assert!(rel <= 2e-3, "{k:?}: α {} vs QDLDL {}", f.alpha, q.alpha);
            assert!(f.alpha >= 12.3, "{k:?}: α {}", f.alpha);
        }
    }

    #[test]
    fn faer_certifies_a_fixed_cube_design_at_nx_8() {
        let model = synthetic_model(8);
        let gamma = 0.3f64.min(0.95 * qpv_solve::conditions::gamma_max(&model).expect("Q"));
        let d = run(
            &model,
            AlphaSpec::Fixed(1.0),
            gamma,
            KktSolver::Faer { threads: 0 },
        );
        assert!(d.feasible() && d.certifies(), "{}", d.summary);
        assert!(d.cube.is_some() && d.recheck(&model).passed);
    }
}
