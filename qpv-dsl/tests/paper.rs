//! The paper's example in matrix and equation form, and the
//! exactness of the polytopic decomposition.

use nalgebra::DMatrix;
use qpv_dsl::{parse, AlphaSpec, GammaSpec, Mode, Model, StateBound};

const MATRIX_FORM: &str = include_str!("../../examples/paper.qpv");
const EQUATION_FORM: &str = include_str!("../../examples/paper_equations.qpv");

fn m(rows: &[[f64; 3]]) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), 3, |i, j| rows[i][j])
}

fn one(src: &str) -> Model {
    let mut models = parse(src).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(models.len(), 1);
    models.remove(0)
}

fn assert_close(a: &DMatrix<f64>, b: &DMatrix<f64>, tol: f64, what: &str) {
    assert_eq!(a.shape(), b.shape(), "{what}: shape");
    let d = (a - b).abs().max();
    assert!(d <= tol, "{what}: differ by {d}\n{a}\n{b}");
}

/// The four vertices (θ1, θ2) = (0,0), (0,1), (1,0), (1,1): A_l, N_{1..3,l}.
fn expected_vertices() -> Vec<(DMatrix<f64>, [DMatrix<f64>; 3])> {
    vec![
        (
            m(&[[-4., 10., 2.], [-1., -1., 1.5], [1., 1., -4.]]),
            [
                m(&[[0.5, 1., 0.], [0., 0., 0.], [0., 1., 0.]]),
                m(&[[-0.4, 0., 1.], [1.5, 0., 1.], [2., 0., 0.]]),
                m(&[[1.5, -0.5, 0.], [3., 0., 0.], [0., 2., 0.]]),
            ],
        ),
        (
            m(&[[-4., 10., 4.], [-1., -2., 1.5], [1., 1., -4.]]),
            [
                m(&[[0.5, 1., 0.], [0., 0., -1.], [0., 2., 0.]]),
                m(&[[-0.4, 0., 1.], [1.5, 0., 2.], [3., 0., 0.]]),
                m(&[[1.5, -0.5, 0.], [3., 0., 0.], [0., 1., 0.]]),
            ],
        ),
        (
            m(&[[-5., 10., 2.], [-1., -1., 3.5], [1., 1., -7.]]),
            [
                m(&[[0.5, 2., 0.], [0., 0., 0.], [0., 1., 0.]]),
                m(&[[-0.4, 0., 0.], [1.5, 0., 1.], [2., 0., 0.]]),
                m(&[[1.5, -1.5, 0.], [4., 0., 0.], [0., 2., 0.]]),
            ],
        ),
        (
            m(&[[-5., 10., 4.], [-1., -2., 3.5], [1., 1., -7.]]),
            [
                m(&[[0.5, 2., 0.], [0., 0., -1.], [0., 2., 0.]]),
                m(&[[-0.4, 0., 0.], [1.5, 0., 2.], [3., 0., 0.]]),
                m(&[[1.5, -1.5, 0.], [4., 0., 0.], [0., 1., 0.]]),
            ],
        ),
    ]
}

#[test]
fn matrix_form_parses_with_the_published_vertices() {
    let model = one(MATRIX_FORM);
    assert_eq!(model.name, "paper_example");
    assert_eq!(
        (model.nx(), model.ny(), model.nu(), model.ntheta()),
        (3, 2, 0, 2)
    );
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    let p = model.polytopic();
    assert_eq!(p.scheduling, vec![0, 1]);
    assert_eq!(p.nv(), 4);
    // the two values the issue states
    assert_eq!(
        p.vertices[0].a,
        m(&[[-4., 10., 2.], [-1., -1., 1.5], [1., 1., -4.]])
    );
    assert_eq!(
        p.vertices[1].n[0],
        m(&[[0.5, 1., 0.], [0., 0., -1.], [0., 2., 0.]])
    );
    let corners = [[0., 0.], [0., 1.], [1., 0.], [1., 1.]];
    for (l, (a, n)) in expected_vertices().iter().enumerate() {
        assert_eq!(p.vertices[l].theta, corners[l].to_vec(), "corner {l}");
        assert_close(&p.vertices[l].a, a, 0.0, &format!("A_{}", l + 1));
        for (k, nk) in n.iter().enumerate() {
            assert_close(
                &p.vertices[l].n[k],
                nk,
                0.0,
                &format!("N_{},{}", k + 1, l + 1),
            );
        }
        assert_eq!(p.vertices[l].b.shape(), (3, 0));
    }
    assert!(!p.output_varies());
    for v in &p.vertices {
        assert_eq!(
            v.c,
            DMatrix::from_row_slice(2, 3, &[1., 0., 0., 0., 1., 0.])
        );
        assert_eq!(v.m[0], m(&[[0., 0., 0.], [0., 0., 1.], [0., 0., 0.]]));
        assert_eq!(v.m[1], m(&[[0., 0., 1.], [0., 0., 0.], [0., 0., 0.]]));
    }
    // μ at the corners picks the corner; the documented order
    let mu = p.mu(&[0.25, 0.5]);
    let want = [0.75 * 0.5, 0.75 * 0.5, 0.25 * 0.5, 0.25 * 0.5];
    for (a, b) in mu.iter().zip(want) {
        assert!((a - b).abs() < 1e-15);
    }
    // region: the box |x_i| <= 0.02
    assert_eq!(p.region.vertices.len(), 8);
    assert_eq!(p.region.facets.len(), 6);
    assert_eq!(p.region.facets[0].as_slice(), &[50., 0., 0.]);
    assert_eq!(p.region.facets[1].as_slice(), &[-50., 0., 0.]);
    assert!(matches!(p.state_bound, StateBound::Given(ref q) if q[(1, 2)] == -0.0022));
    assert_eq!(p.designs.len(), 2);
    assert_eq!(p.designs[0].alpha, AlphaSpec::Fixed(10.0));
    assert_eq!(p.designs[0].gamma, GammaSpec::Fixed(0.4));
    assert_eq!(p.designs[0].mode, Mode::Paper);
    assert_eq!(p.designs[1].alpha, AlphaSpec::Max);
    assert_eq!(p.designs[1].gamma, GammaSpec::Search);
    assert_eq!(p.designs[1].mode, Mode::Sound);
}

#[test]
fn equation_form_gives_the_same_polytopic_model() {
    let a = one(MATRIX_FORM);
    let b = one(EQUATION_FORM);
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);
    assert_eq!(a.a, b.a);
    assert_eq!(a.n, b.n);
    assert_eq!(a.c, b.c);
    assert_eq!(a.m, b.m);
    let (pa, pb) = (a.polytopic(), b.polytopic());
    // identical numbers (spans of declarations differ between the files)
    assert_eq!(pa.vertices, pb.vertices);
    assert_eq!(pa.scheduling, pb.scheduling);
    assert_eq!(pa.region, pb.region);
    assert_eq!(pa.state_bound, pb.state_bound);
    for (x, y) in pa.designs.iter().zip(&pb.designs) {
        assert_eq!((x.alpha, x.gamma, x.mode), (y.alpha, y.gamma, y.mode));
    }
}

/// A tiny deterministic PRNG (xorshift64*).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn check_exact(model: &Model, rng: &mut Rng, samples: usize) {
    let p = model.polytopic();
    for _ in 0..samples {
        let theta: Vec<f64> = model
            .params
            .iter()
            .map(|q| q.lo + (q.hi - q.lo) * rng.unit())
            .collect();
        let mu = p.mu(&theta);
        assert!(mu.iter().all(|w| *w >= 0.0));
        assert!((mu.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_close(&p.a_at(&theta), &model.eval_a(&theta), 1e-12, "A");
        assert_close(&p.b_at(&theta), &model.eval_b(&theta), 1e-12, "B");
        for (x, y) in p.n_at(&theta).iter().zip(model.eval_n(&theta)) {
            assert_close(x, &y, 1e-12, "N");
        }
    }
}

#[test]
fn polytopic_decomposition_is_exact_at_random_theta() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    check_exact(&one(MATRIX_FORM), &mut rng, 1000);
    check_exact(&one(EQUATION_FORM), &mut rng, 1000);
    // multi-affine products, inputs, three parameters with other bounds, one unused
    let src = "model t {
        state x1, x2; input u; output y;
        param a in [-1, 2]; param b in [0.5, 3]; param c in [-2, -1]; param unused in [0, 1];
        der x1 = (1 + a*b)*x1 - a*b*c*x2 + (2 - c)*x1*x2 + (a + b)*u;
        der x2 = -x2 + c*x1^2 + a*b*u;
        out y = x1;
        region box([1, 2]);
    }";
    let model = one(src);
    assert_eq!(model.warnings.len(), 1, "{:?}", model.warnings);
    assert!(model.warnings[0].message.contains("`unused`"));
    let p = model.polytopic();
    assert_eq!(p.scheduling, vec![0, 1, 2]);
    assert_eq!(p.nv(), 8);
    assert_eq!(
        p.vertices[0].theta[3], 0.5,
        "unused parameter at its midpoint"
    );
    check_exact(&model, &mut rng, 2000);
}

#[test]
fn all_examples_parse_and_their_bounds_contain_the_region() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut count = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("qpv") {
            continue;
        }
        let src = std::fs::read_to_string(&path).unwrap();
        let models = parse(&src).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for model in &models {
            if model.is_lpv() {
                // The global observer: no region or state bound to check.
                assert!(
                    model.region.is_none(),
                    "{}: LPV with a region",
                    path.display()
                );
                // a term scheduled on a measured output is reported
                assert!(
                    model
                        .warnings
                        .iter()
                        .all(|w| w.message.contains("is scheduled on the measured output")),
                    "{}",
                    path.display()
                );
                count += 1;
                continue;
            }
            assert!(
                model.warnings.is_empty(),
                "{}: {:?}",
                path.display(),
                model.warnings
            );
            assert!(
                !model.designs.is_empty(),
                "{}: no design request",
                path.display()
            );
            let q = match &model.state_bound {
                StateBound::Given(q) => q,
                // computed by the solver (qpv-solve's state_bound module)
                StateBound::Auto { .. } => {
                    check_exact(model, &mut Rng(7), 200);
                    continue;
                }
                StateBound::None => panic!("{}: no state bound", path.display()),
            };
            let qinv = q.clone().try_inverse().unwrap();
            let (worst, _) = model.region.max_quadratic(&qinv).unwrap();
            assert!(
                worst <= 1.0,
                "{}: region not inside Q ({worst})",
                path.display()
            );
            check_exact(model, &mut Rng(7), 200);
        }
        count += 1;
    }
    assert!(
        count >= 5,
        "expected the paper examples and at least three more"
    );
}
