//! A table of bad inputs: each must fail at the right line and column with a
//! message that says what is wrong and what was expected (never a grammar
//! rule name).

use qpv_dsl::parse;

const BASE: &str = "model m {
    state x1, x2;
    output y;
    param th in [0, 1];
    A = [-1, th; 0, -2];
    C = [1, 0];
    region box(1);
}
";

/// (what, input, line, column, expected text of the error at that point,
/// a fragment of the message)
fn cases() -> Vec<(
    &'static str,
    String,
    usize,
    usize,
    &'static str,
    &'static str,
)> {
    let r = |from: &str, to: &str| {
        assert!(BASE.contains(from), "{from}");
        BASE.replacen(from, to, 1)
    };
    vec![
        ("missing comma", r("x1, x2", "x1 x2"), 2, 14, "x2", "expected `,` or `;`, found `x2`"),
        ("typo in keyword", r("state x1", "stat x1"), 2, 5, "stat", "unknown statement `stat`: did you mean `state`?"),
        ("unknown statement", r("state x1", "foo x1"), 2, 5, "foo", "unknown statement `foo`"),
        ("unterminated model", r("}\n", ""), 8, 1, "", "the `{` at 1:9 is never closed"),
        ("unterminated matrix", r("0, -2]", "0, -2"), 6, 7, "=", "expected an operator (`+ - * / ^`), `,`, `;` or `]`, found `=`"),
        ("short row", r("[-1, th; 0, -2]", "[-1, th; 0]"), 5, 18, "0", "row 2 of A has 1 entry, expected 2 (one per state)"),
        ("too few rows", r("[-1, th; 0, -2]", "[-1, th]"), 5, 9, "[-1, th]", "A must have 2 rows (one per state), found 1"),
        ("wrong C width", r("C = [1, 0]", "C = [1, 0, 0]"), 6, 10, "1, 0, 0", "row 1 of C has 3 entries, expected 2 (one per state)"),
        ("unknown parameter", r("-1, th;", "-1, th2;"), 5, 14, "th2", "unknown name `th2` in an entry of A: expected a declared parameter or a number (did you mean `th`?)"),
        ("division by a parameter that reaches 0", r("-1, th;", "-1, 1/th;"), 5, 16, "th", "`1/th` is not defined on the whole parameter box: it is not finite at th = 0"),
        ("sqrt of a negative value", r("-1, th;", "-1, sqrt(th - 0.5);"), 5, 14, "sqrt(th - 0.5)", "`sqrt(th - 0.5)` is not defined on the whole parameter box"),
        ("ln of zero", r("-1, th;", "-1, ln(th);"), 5, 14, "ln(th)", "`ln(th)` is not defined on the whole parameter box: it is not finite at th = 0"),
        ("tan through a pole", r("-1, th;", "-1, tan(3*th);"), 5, 14, "tan(3*th)", "tan of `3*th`, which reaches a pole"),
        ("unbounded exp", r("-1, th;", "-1, exp(1000*th);"), 5, 14, "exp(1000*th)", "`exp(1000*th)` is not defined on the whole parameter box"),
        ("unknown function", r("-1, th;", "-1, sinn(th);"), 5, 14, "sinn", "unknown function `sinn` (did you mean `sin`?)"),
        ("function of a constant that is undefined", r("-1, th;", "-1, sqrt(-1);"), 5, 14, "sqrt", "`sqrt(-1)` is not defined"),
        ("state in a denominator of an output", r("C = [1, 0];", "out y = x1/(1 + x2);"), 6, 16, "(1 + x2)", "has the state `x2` in a denominator: the QPV class allows states only polynomially"),
        ("state inside a function of an output", r("C = [1, 0];", "out y = sin(x1);"), 6, 13, "sin(x1)", "has the state `x1` inside the function `sin`"),
        ("state inside a function of an output: measured-signal hint", r("C = [1, 0];", "out y = sin(x1);"), 6, 13, "sin(x1)", "schedule on the measurement instead: declare it as a parameter"),
        ("parameter inside a nonlinear term", r("A = [-1, th; 0, -2];", "der x1 = -x1 + th*sin(x1); der x2 = -2*x2;"), 5, 20, "th", "`th` is a scheduling parameter inside a nonlinear term of the states"),
        ("input inside a nonlinear term", r("A = [-1, th; 0, -2];", "der x1 = -x1 + sin(x1 + u); der x2 = -2*x2 + u;").replace("output y;", "output y; input u;"), 5, 29, "u", "`u` is an input inside a nonlinear term of the states: inputs enter linearly only"),
        ("let used before its definition", r("A = [-1, th; 0, -2];", "let a = b*th; let b = 2 + th; A = [-1, a; 0, -2];"), 5, 13, "b", "`b` is used before its definition"),
        ("parameter in a const", r("A = [-1, th; 0, -2];", "const g = th; A = [-1, th; 0, -2];"), 5, 15, "th", "parameter `th` cannot appear in a `const` definition"),
        ("state in a let", r("A = [-1, th; 0, -2];", "let s = x1; A = [-1, s; 0, -2];"), 5, 13, "x1", "state `x1` cannot appear in the definition of `s`"),
        ("let in the region", r("region box(1);", "region box(s); let s = 1 + th;"), 7, 16, "s", "`s` is a function of the parameters and cannot appear in the region"),
        ("let named like a state", r("A = [-1, th; 0, -2];", "let x1 = th; A = [-1, th; 0, -2];"), 5, 9, "x1", "`x1` is already declared as a state"),
        ("division by zero", r("-1, th;", "-1, 1/(2-2);"), 5, 16, "(2-2)", "division by zero"),
        ("state in a matrix", r("-1, th;", "-1, x1;"), 5, 14, "x1", "state `x1` cannot appear in an entry of A"),
        ("implicit multiplication", r("-1, th;", "-1, 2th;"), 5, 15, "th", "(write multiplication explicitly, e.g. `2*x1`)"),
        ("dangling operator", r("-1, th;", "-1, 1 +;"), 5, 17, ";", "expected an expression (a number, a name or `(`), found `;`"),
        ("junk character", r("-1, th;", "-1, $;"), 5, 14, "$", "found `$`"),
        ("nested brackets", r("[-1, th; 0, -2]", "[[-1, th], [0, -2]]"), 5, 10, "[", "matrix rows are separated by `;`"),
        ("non-ASCII name", r("[0, 1]", "[0, θ]"), 4, 21, "θ", "names use ASCII letters"),
        ("empty bounds", r("[0, 1]", "[1, 1]"), 4, 17, "[1, 1]", "empty parameter range [1, 1]"),
        ("negative rate", r("[0, 1];", "[0, 1] rate -2;"), 4, 24, "rate -2", "parameter rate bound -2: expected a finite number ≥ 0"),
        ("state in a rate", r("[0, 1];", "[0, 1] rate x1;"), 4, 29, "x1", "state `x1` cannot appear in a rate bound"),
        ("reversed bounds", r("[0, 1]", "[1, 0]"), 4, 17, "[1, 0]", "reversed parameter range [1, 0]: the lower bound comes first, write [0, 1]"),
        ("parameter in a bound", r("[0, 1]", "[0, th]"), 4, 21, "th", "parameter `th` cannot appear in a parameter bound: a constant number is expected"),
        ("huge number", r("[0, 1]", "[0, 1e999]"), 4, 21, "1e999", "the number `1e999` is too large"),
        ("bad exponent", r("-1, th;", "-1, th^0.5;"), 5, 17, "0.5", "the exponent of `^` must be a whole number"),
        ("duplicate name", r("output y;", "output y, x1;"), 3, 15, "x1", "`x1` is already declared as a state at 2:11"),
        ("duplicate matrix", r("C = [1, 0];", "C = [1, 0]; A = [1, 0; 0, 1];"), 6, 17, "A", "A is defined twice (first at 5:5)"),
        ("unknown matrix", r("C = [1, 0];", "C = [1, 0]; Q = [1, 0; 0, 1];"), 6, 17, "Q", "unknown matrix `Q`: expected A, B, B_w, C, N1..N2 or M1 (the state bound is written `state_bound Q = [...];`)"),
        ("N out of range", r("C = [1, 0];", "C = [1, 0]; N3 = 0;"), 6, 17, "N3", "`N3` does not exist: the model has 2 states, so N1..N2"),
        ("missing N_k", r("C = [1, 0];", "C = [1, 0]; N1 = [1, 0; 0, 0];"), 6, 17, "N1", "N2 is missing (N1 given): give all of N1..N2"),
        ("N as a non-zero scalar", r("C = [1, 0];", "C = [1, 0]; N1 = 0; N2 = 1;"), 6, 30, "1", "N2 must be a matrix `[...]` of size 2×2; only `0` may stand for a whole (zero) matrix"),
        ("B without inputs", r("C = [1, 0];", "C = [1, 0]; B = [1; 0];"), 6, 17, "B", "B is given but the model declares no inputs"),
        ("inputs without B", r("output y;", "output y; input u;"), 1, 7, "m", "declares inputs (u) but gives no `B = [...];` (2×1)"),
        ("no states", r("state x1, x2;", ""), 1, 7, "m", "model `m` declares no states"),
        ("no outputs", r("output y;", ""), 1, 7, "m", "model `m` declares no outputs"),
        ("no dynamics", r("A = [-1, th; 0, -2];", ""), 1, 7, "m", "model `m` has no dynamics"),
        // A QPV plant needs a region (an LPV one does not: its observer is global).
        ("no region", r("region box(1);", "N1 = [0, 1; 0, 0]; N2 = 0;"), 1, 7, "m", "model `m` has no region"),
        ("two regions", r("region box(1);", "region box(1); region box(2);"), 7, 20, "region box(2);", "the region is given twice (first at 7:5)"),
        ("negative radius", r("box(1)", "box(-1)"), 7, 16, "-1", "a box radius must be positive, found -1"),
        ("wrong number of radii", r("box(1)", "box([1, 2, 3])"), 7, 16, "[1, 2, 3]", "box radii: expected 2 values (one per state), found 3"),
        ("origin outside", r("region box(1);", "region vertices [1, 0; 0, 1; 1, 1];"), 7, 21, "[1, 0; 0, 1; 1, 1]", "the origin must lie strictly inside the region"),
        ("unbounded", r("region box(1);", "region halfspaces [1, 0; -1, 0; 0, 1];"), 7, 23, "[1, 0; -1, 0; 0, 1]", "the region is unbounded"),
        ("vertex of wrong size", r("region box(1);", "region vertices [1, 0; 0, 1, 2; -1, -1];"), 7, 28, "0, 1, 2", "vertex 2 has 3 coordinates, expected 2 (one per state)"),
        ("state in the region", r("box(1)", "box(x1)"), 7, 16, "x1", "state `x1` cannot appear in the region: a constant number is expected"),
        ("unsymmetric Q", r("region box(1);", "region box(1); state_bound Q = [1, 2; 3, 4];"), 7, 43, "3", "Q must be symmetric: entry (2, 1) is 3 but entry (1, 2) is 2"),
        ("indefinite Q", r("region box(1);", "region box(1); state_bound Q = [1, 2; 2, 1];"), 7, 36, "[1, 2; 2, 1]", "Q must be positive definite"),
        ("overflow on the parameter box", r("-1, th;", "-1, 1e308*(1+th);"), 5, 14, "1e308*(1+th)", "the value of `1e308*(1+th)` overflows a 64-bit float on the parameter box"),
        ("huge matrix entry", r("-1, th;", "-1, 1e200;"), 5, 14, "1e200", "the value of `1e200` reaches 1e200 in magnitude"),
        ("overflow in an equation", r("A = [-1, th; 0, -2];", "der x1 = -x1 + 1e308*(1+th)*x2; der x2 = -2*x2;"), 5, 20, "1e308*(1+th)*x2", "overflows a 64-bit float on the parameter box"),
        ("huge parameter range", r("[0, 1]", "[-1e308, 1e308]"), 4, 17, "[-1e308, 1e308]", "is too wide: bounds up to 1e100"),
        ("huge Q entry", r("region box(1);", "region box(1); state_bound Q = [1e300, 0; 0, 1];"), 7, 36, "[1e300, 0; 0, 1]", "Q has an entry of magnitude 1e300"),
        ("badly scaled Q", r("region box(1);", "region box(1); state_bound Q = [1e20, 0; 0, 1e-6];"), 7, 36, "[1e20, 0; 0, 1e-6]", "Q is too badly scaled to be certified in double precision"),
        ("tiny box radius", r("box(1)", "box(1e-320)"), 7, 5, "region box(1e-320);", "cannot be represented reliably in double precision"),
        ("halfspaces with overflowing vertices", r("region box(1);", "region halfspaces [1e-320, 0; -1e-320, 0; 0, 1; 0, -1];"), 7, 23, "[1e-320, 0; -1e-320, 0; 0, 1; 0, -1]", "cannot be represented reliably in double precision"),
        ("Q of wrong size", r("region box(1);", "region box(1); state_bound Q = [1];"), 7, 37, "1", "row 1 of Q has 1 entry, expected 2"),
        ("state bound not named Q", r("region box(1);", "region box(1); state_bound P = [1, 0; 0, 1];"), 7, 32, "P", "expected `Q` (write `state_bound Q = [...]`) or `auto`, found `P`"),
        ("unknown state bound option", r("region box(1);", "region box(1); state_bound auto(k = 2);"), 7, 37, "k", "unknown state bound option `k`: expected `h`"),
        ("negative h", r("region box(1);", "region box(1); state_bound auto(h = -2);"), 7, 41, "-2", "`h` must be a positive number, found `-2`"),
        ("h inside the region", r("region box(1);", "region box(1); state_bound auto(h = 0.5);"), 7, 41, "0.5", "`h` = 0.5 is too small: F must contain the region"),
        ("h twice", r("region box(1);", "region box(1); state_bound auto(h = 2, h = 3);"), 7, 44, "h", "`h` is set twice (first at 7:37)"),
        ("state in h", r("region box(1);", "region box(1); state_bound auto(h = x1);"), 7, 41, "x1", "state `x1` cannot appear in the state bound option h"),
        ("state_bound auto with disturbances", r("region box(1);", "region box(1); disturbance w; B_w = [1; 0]; state_bound auto;"), 7, 49, "", "`state_bound auto` computes an invariant ellipsoid of the undisturbed plant"),
        ("auto without parentheses", r("region box(1);", "region box(1); state_bound auto h = 2;"), 7, 37, "h", "expected `(` or `;`, found `h`"),
        ("empty auto options", r("region box(1);", "region box(1); state_bound auto();"), 7, 37, ")", "expected a state bound option (`h = ...`), found `)`"),
        ("auto and Q", r("region box(1);", "region box(1); state_bound auto; state_bound Q = [2, 0; 0, 2];"), 7, 38, "state_bound Q = [2, 0; 0, 2];", "the state bound is given twice (first at 7:20)"),
        ("unknown design key", r("region box(1);", "region box(1); design { alpha = 10; beta = 2; }"), 7, 41, "beta", "unknown design setting `beta`: expected `alpha`, `gamma`, `mode`, `split`, `conditions`, `output_route`, `noise`, `max_gain`, `sample`, `float`, `poles`, `output_std`, `process_std` or `noise_period`"),
        ("unknown float", r("region box(1);", "region box(1); design { float = f16; }"), 7, 37, "f16", "`float` must be `f64` (the default) or `f32`, found `f16`"),
        ("reversed input range", r("region box(1);", "region box(1); input w1, w2 in [2, 1];"), 7, 36, "[2, 1]", "input range [2, 1]: expected finite bounds, the lower one first"),
        ("unknown output route", r("region box(1);", "region box(1); design { output_route = kalman; }"), 7, 44, "kalman", "`output_route` must be `double_sum` or `filter` (optionally `filter(pole = .., gain = ..)`), found `kalman`"),
        ("unknown option of alpha = max", r("region box(1);", "region box(1); design { alpha = max(h = 1); }"), 7, 41, "h", "unknown option `h` of `alpha = max`: expected `within`"),
        ("options on a fixed alpha", r("region box(1);", "region box(1); design { alpha = 10(within = 0.1); }"), 7, 39, "(within = 0.1)", "only `alpha = max` takes options"),
        ("within out of range", r("region box(1);", "region box(1); design { alpha = max(within = 0.9); }"), 7, 50, "0.9", "`within` must be a fraction from 0 (the fastest point found) to 0.5"),
        ("options on gamma", r("region box(1);", "region box(1); design { gamma = search(h = 1); }"), 7, 43, "(h = 1)", "`gamma` takes no options in parentheses"),
        ("negative max_gain", r("region box(1);", "region box(1); design { max_gain = -1; }"), 7, 40, "-1", "`max_gain` must be a positive number"),
        ("negative sample", r("region box(1);", "region box(1); design { sample = -1e-3; }"), 7, 38, "-1e-3", "`sample` must be a positive sample period in seconds"),
        ("zero sample", r("region box(1);", "region box(1); design { sample = 0; }"), 7, 38, "0", "`sample` must be a positive sample period in seconds (e.g. `sample = 1e-4` for 10 kHz), found `0`"),
        ("state in sample", r("region box(1);", "region box(1); design { sample = x1; }"), 7, 38, "x1", "x1"),
        ("sample with cube", r("region box(1);", "region box(1); design { conditions = cube; sample = 1e-3; }"), 7, 29, "conditions", "has no discrete-time form in qpv yet"),
        ("sample in paper mode", r("region box(1);", "region box(1); design { mode = paper; sample = 1e-3; }"), 7, 29, "mode", "`sample` needs `mode = sound`"),
        ("sample twice", r("region box(1);", "region box(1); design { sample = 1e-3; sample = 1e-2; }"), 7, 44, "sample", "`sample` is set twice in this design block"),
        ("max_gain with noise = min", r("region box(1);", "region box(1); design { alpha = 1; noise = min; max_gain = 5; }"), 7, 53, "max_gain", "`max_gain` cannot be combined with `noise = min`"),
        ("options on double_sum", r("region box(1);", "region box(1); design { output_route = double_sum(pole = 1); }"), 7, 54, "(pole = 1)", "`double_sum` takes no options"),
        ("unknown filter option", r("region box(1);", "region box(1); design { output_route = filter(poles = 3); }"), 7, 51, "poles", "unknown filter option `poles`: expected `pole`"),
        ("filter option typo hint", r("region box(1);", "region box(1); design { output_route = filter(poles = 3); }"), 7, 51, "poles", "(did you mean `pole`?)"),
        ("negative filter pole", r("region box(1);", "region box(1); design { output_route = filter(pole = -2); }"), 7, 58, "-2", "`pole` must be a positive number (the filter pole is -pole), found `-2`"),
        ("zero filter gain", r("region box(1);", "region box(1); design { output_route = filter(gain = 0); }"), 7, 58, "0", "`gain` must be a nonzero number, found `0`"),
        ("duplicate filter pole", r("region box(1);", "region box(1); design { output_route = filter(pole = 1, pole = 2); }"), 7, 61, "pole", "`pole` is set twice (first at 7:51)"),
        ("filter pole not a number", r("region box(1);", "region box(1); design { output_route = filter(pole = x1); }"), 7, 58, "x1", "x1"),
        ("filter option without =", r("region box(1);", "region box(1); design { output_route = filter(pole 3); }"), 7, 56, "3", "expected `=`"),
        ("empty filter options", r("region box(1);", "region box(1); design { output_route = filter(); }"), 7, 51, ")", "expected an option `name = value` (e.g. `pole = 40`)"),
        ("output route twice", r("region box(1);", "region box(1); design { output_route = filter; output_route = double_sum; }"), 7, 52, "output_route", "`output_route` is set twice in this design block"),
        ("undefined function in C", r("C = [1, 0]", "C = [1, 1/th]"), 6, 15, "th", "`1/th` is not defined on the whole parameter box"),
        ("skew slack in paper mode", r("region box(1);", "region box(1); design { mode = paper; split = skew_slack; }"), 7, 43, "split", "`split = skew_slack` needs `mode = sound`"),
        ("unknown split", r("region box(1);", "region box(1); design { split = sym; }"), 7, 37, "sym", "`split` must be `as_written`, `symmetric` or `skew_slack`, found `sym`"),
        ("numeric split", r("region box(1);", "region box(1); design { split = 2; }"), 7, 37, "2", "`split` must be `as_written`, `symmetric` or `skew_slack`, found `2`"),
        ("noise min at alpha max", r("region box(1);", "region box(1); design { alpha = max; noise = min; }"), 7, 42, "noise", "`noise = min` needs a fixed `alpha`"),
        ("noise min by default alpha max", r("region box(1);", "region box(1); design { noise = min; }"), 7, 29, "noise", "`alpha = max` is the fastest certified design"),
        ("noise min in paper mode", r("region box(1);", "region box(1); design { alpha = 5; mode = paper; noise = min; }"), 7, 40, "mode", "`noise = min` needs `mode = sound`"),
        ("noise min with skew slack", r("region box(1);", "region box(1); design { alpha = 5; split = skew_slack; noise = min; }"), 7, 40, "split", "`noise = min` does not search the skew slack"),
        ("unknown noise objective", r("region box(1);", "region box(1); design { noise = low; }"), 7, 37, "low", "`noise` must be `free` (the default), `min` or `rms`, found `low`"),
        ("noise set twice", r("region box(1);", "region box(1); design { alpha = 5; noise = min; noise = free; }"), 7, 53, "noise", "`noise` is set twice in this design block"),
        ("noise on a state", r("region box(1);", "region box(1); noise x1;"), 7, 26, "x1", "`noise x1`: `x1` is a state, not an output: measurement noise is declared on outputs"),
        ("noise on an unknown name", r("region box(1);", "region box(1); noise z;"), 7, 26, "z", "`noise z`: `z` is not a declared output"),
        ("noise declared twice", r("region box(1);", "region box(1); noise y; noise y;"), 7, 29, "noise y;", "`noise` is declared twice (first at 7:20)"),
        ("noise output listed twice", r("region box(1);", "region box(1); noise y, y;"), 7, 29, "y", "`y` is listed twice in the `noise` declaration"),
        ("disturbance without B_w", r("region box(1);", "region box(1); disturbance w;"), 7, 32, "w", "declares disturbances (w) but gives no `B_w = [...];` (2×1, one column per disturbance)"),
        ("unknown unit of time", r("region box(1);", "region box(1); time = fortnights;"), 7, 27, "fortnights", "unknown unit of time `fortnights`: expected `seconds`, `milliseconds`, `minutes`, `hours`, `days`"),
        ("time declared twice", r("region box(1);", "region box(1); time = h; time = days;"), 7, 30, "time = days;", "`time` is declared twice (first at 7:20)"),
        ("B_w without disturbance", r("region box(1);", "region box(1); B_w = [1; 0];"), 7, 20, "B_w", "B_w is given but the model declares no disturbances"),
        ("B_w of the wrong size", r("region box(1);", "region box(1); disturbance w; B_w = [1, 0; 0, 1];"), 7, 42, "1, 0", "row 1 of B_w has 2 entries, expected 1 (one per disturbance)"),
        ("B_w with too few rows", r("region box(1);", "region box(1); disturbance w; B_w = [1];"), 7, 41, "[1]", "B_w must have 2 rows (one per state), found 1"),
        ("disturbance named like a state", r("region box(1);", "region box(1); disturbance x1;"), 7, 32, "x1", "`x1` is already declared as a state"),
        ("disturbance in an out equation", r("C = [1, 0];", "disturbance w; B_w = [1; 0]; out y = x1 + w;"), 6, 47, "w", "`out y` depends on the disturbance `w`: disturbances enter the state equations only"),
        ("disturbance times a state", r("A = [-1, th; 0, -2];", "disturbance w; der x1 = -x1 + x2*w; der x2 = -2*x2;"), 5, 35, "x2*w", "has disturbance `w` multiplied by state `x2`: disturbances may only enter linearly, as B_w(θ)w"),
        ("disturbance in no equation", r("A = [-1, th; 0, -2];", "disturbance w; der x1 = -x1 + th*x2; der x2 = -2*x2;"), 5, 17, "w", "disturbance `w` enters no equation"),
        ("B_w and der equations", r("A = [-1, th; 0, -2];", "disturbance w; B_w = [1; 0]; der x1 = -x1 + w; der x2 = -2*x2;"), 5, 20, "B_w", "B_w is given as a matrix, but the dynamics are also written as equations"),
        ("disturbance in a matrix entry", r("region box(1);", "region box(1); disturbance w; B_w = [w; 0];"), 7, 42, "w", "disturbance `w` cannot appear in an entry of B_w"),
        ("cube on a triangle", r("region box(1);", "region vertices [1, 0; 0, 1; -1, -1]; design { conditions = cube; }"), 7, 52, "conditions", "`conditions = cube` needs a region that is a box, a parallelotope or a zonotope"),
        ("flat zonotope", r("region box(1);", "region zonotope [1, 1; 2, 2];"), 7, 21, "[1, 1; 2, 2]", "the generators do not span the space"),
        ("unknown conditions", r("region box(1);", "region box(1); design { conditions = partial; }"), 7, 42, "partial", "`conditions` must be `full`, `decoupled`, `cube` or `auto`, found `partial`"),
        ("duplicate split", r("region box(1);", "region box(1); design { split = symmetric; split = as_written; }"), 7, 48, "split", "`split` is set twice in this design block"),
        ("design key typo split", r("region box(1);", "region box(1); design { splt = symmetric; }"), 7, 29, "splt", "(did you mean `split`?)"),
        ("design key typo", r("region box(1);", "region box(1); design { gama = 0.5; }"), 7, 29, "gama", "(did you mean `gamma`?)"),
        ("duplicate design key", r("region box(1);", "region box(1); design { mode = paper; mode = sound; }"), 7, 43, "mode", "`mode` is set twice in this design block"),
        ("negative alpha", r("region box(1);", "region box(1); design { alpha = -1; }"), 7, 37, "-1", "`alpha` must be a positive number or `max`, found `-1`"),
        ("gamma out of range", r("region box(1);", "region box(1); design { gamma = 1; }"), 7, 37, "1", "`gamma` must be a number strictly between 0 and 1 or `search`, found `1`"),
        ("unknown mode", r("region box(1);", "region box(1); design { mode = fast; }"), 7, 36, "fast", "`mode` must be `sound` or `paper`, found `fast`"),
        ("unterminated design", r("region box(1);\n}\n", "region box(1); design { alpha = 1;\n"), 8, 1, "", "expected a design setting (`alpha`, `gamma`, `mode`, `split`, `conditions`, `output_route` or `noise`) or `}`, found the end of the input (the `{` at 7:27 is never closed)"),
        ("constant term", r("A = [-1, th; 0, -2];", "der x1 = -x1 + th*x2; der x2 = -2*x2 + 5;"), 5, 44, "5", "`der x2` has a constant term (`5`)"),
        ("parameter-only term", r("A = [-1, th; 0, -2];", "der x1 = -x1 + th; der x2 = -2*x2;"), 5, 20, "th", "`der x1` has the term th without a state"),
        ("cubic term", r("A = [-1, th; 0, -2];", "der x1 = -x1 + x1*x2*x1; der x2 = -2*x2;"), 5, 20, "x1*x2*x1", "of degree 3 in the states"),
        ("cubic term: the scheduling rewrite", r("A = [-1, th; 0, -2];", "der x1 = -x1 + x1*x2*x1; der x2 = -2*x2;"), 5, 20, "x1*x2*x1", "Its factor `x1` is measured (the output `y`), so the term can be scheduled on `y` exactly, but the interval of that parameter is derived from a given state bound and the model has no state bound: declare `param p = y in [lo, hi];` with [lo, hi] covering `y` over F (the certificate checks it); the term is then written as `p^2*x2` automatically"),
        ("measured parameter of a state", r("param th in [0, 1];", "param th in [0, 1]; param p = x1 in [-1, 1];"), 4, 35, "x1", "`x1` is a state, not an output"),
        ("measured parameter of an unknown output", r("param th in [0, 1];", "param th in [0, 1]; param p = yy in [-1, 1];"), 4, 35, "yy", "`yy` is not a declared output (did you mean `y`?)"),
        ("measured parameter without a bound", r("param th in [0, 1];", "param th in [0, 1]; param p = y in [-1, 1];"), 4, 35, "y", "nothing bounds the output `y`"),
        ("measured parameter without an interval", r("param th in [0, 1];", "param th in [0, 1]; param p = y;"), 4, 35, "y", "it can only be derived from a given state bound"),
        ("two measured names", r("param th in [0, 1];", "param th in [0, 1]; param p, q = y;"), 4, 34, "q", "is declared alone"),
        ("measured interval too narrow", r("region box(1);", "region box(1); state_bound Q = [4, 0; 0, 4]; param p = y in [-1, 1];"), 7, 65, "[-1, 1]", "does not cover the output `y` over the state bound F: y ranges over [-2, 2] there"),
        ("Van der Pol as written", r("A = [-1, th; 0, -2];", "der x1 = x2; der x2 = th*x2 - th*x1^2*x2 - x1;"), 5, 35, "th*x1^2*x2", "the term is then written as `p^2*th*x2` automatically"),
        ("cubic term of an output", r("C = [1, 0];", "out y = x1*x2*x1;"), 6, 13, "x1*x2*x1", "of degree 3 in the states"),
        ("cubic term of an output: the scheduling rewrite", r("C = [1, 0];", "out y = x1*x2*x1;"), 6, 13, "x1*x2*x1", "a factor that is a measured output is scheduled on it automatically"),
        ("input times state", r("A = [-1, th; 0, -2];", "der x1 = -x1 + u*x1; der x2 = -2*x2;").replace("output y;", "output y; input u;"), 5, 20, "u*x1", "input `u` multiplied by state `x1`: inputs may only enter linearly"),
        ("missing der", r("A = [-1, th; 0, -2];", "der x1 = -x1 + th*x2;"), 1, 7, "m", "no equation for the state `x2`: add `der x2 = ...;`"),
        ("duplicate der", r("A = [-1, th; 0, -2];", "der x1 = -x1; der x2 = -x2; der x1 = x2;"), 5, 37, "x1", "`der x1` is given twice (first at 5:5)"),
        ("der of unknown state", r("A = [-1, th; 0, -2];", "der x1 = -x1; der x3 = -x2;"), 5, 23, "x3", "`der x3`: `x3` is not a declared state"),
        ("der of an output", r("A = [-1, th; 0, -2];", "der x1 = -x1; der y = -x2;"), 5, 23, "y", "`der y`: `y` is an output, not a state (write `out y = ...;` for an output)"),
        ("mixed forms", r("C = [1, 0];", "C = [1, 0]; der x1 = -x1; der x2 = -x2;"), 5, 5, "A", "A is given as a matrix, but the dynamics are also written as equations"),
        ("output used in an expression", r("A = [-1, th; 0, -2];", "der x1 = -y; der x2 = -x2;"), 5, 15, "y", "`y` is an output: outputs cannot appear in expressions"),
        ("feedthrough", r("C = [1, 0];", "out y = x1 + u;").replace("output y;", "output y; input u;").replace("A = [-1, th; 0, -2];", "A = [-1, th; 0, -2]; B = [1; 0];"), 6, 18, "u", "direct feedthrough"),
        ("unterminated comment", BASE.to_string() + "/* open", 9, 1, "/*", "unterminated comment: `/*` has no closing `*/`"),
        ("empty input", String::new(), 1, 1, "", "expected a model `model NAME { ... }`, found the end of the input"),
        ("junk after a model", BASE.to_string() + "junk", 9, 1, "junk", "expected a model `model NAME { ... }` or the end of the input, found `junk`"),
        ("keyword as a name", r("state x1, x2;", "state x1, in;"), 2, 15, "in", "expected a name, found the keyword `in`"),
        ("duplicate model", BASE.to_string() + BASE, 9, 7, "m", "a model named `m` is already defined at 1:7"),
        ("cover of an unknown parameter", r("region box(1);", "region box(1); cover tj into 4;"), 7, 26, "tj", "unknown parameter `tj` in `cover` (did you mean `th`?)"),
        ("cover of a state", r("region box(1);", "region box(1); cover x1 into 4;"), 7, 26, "x1", "`x1` is a state, not a parameter"),
        ("cover of an unused parameter", r("param th in [0, 1];", "param th in [0, 1]; param p in [0, 1]; cover p into 2;"), 4, 50, "p", "parameter `p` appears in no matrix and no scheduling function"),
        ("cover into 0 pieces", r("region box(1);", "region box(1); cover th into 0;"), 7, 34, "0", "the number of pieces must be at least 1, found 0"),
        ("cover into a fraction", r("region box(1);", "region box(1); cover th into 2.5;"), 7, 34, "2.5", "the number of pieces must be a whole number, found 2.5"),
        ("cover into too many pieces", r("region box(1);", "region box(1); cover th into 1000;"), 7, 34, "1000", "1000 pieces: at most 64 are supported"),
        ("cover twice", r("region box(1);", "region box(1); cover th into 2; cover th into 3;"), 7, 37, "cover th into 3;", "a `cover` statement is already given at 7:20"),
        ("cover cuts a parameter twice", r("region box(1);", "region box(1); cover th into 2, th into 3;"), 7, 37, "th", "`th` is cut twice"),
        ("cover without a count", r("region box(1);", "region box(1); cover th into;"), 7, 33, ";", "expected an expression"),
        ("cover without into", r("region box(1);", "region box(1); cover th 4;"), 7, 29, "4", "expected `into`"),
        ("deep nesting", r("-1, th;", &format!("-1, {}1{};", "(".repeat(70), ")".repeat(70))), 5, 76, "(", "brackets nested too deeply"),
    ]
}

#[test]
fn error_table() {
    let mut failures = Vec::new();
    for (what, src, line, col, at, fragment) in cases() {
        match parse(&src) {
            Ok(_) => failures.push(format!("{what}: parsed without error")),
            Err(e) => {
                let text = &src[e.span.start..e.span.end];
                let ok = e.line == line
                    && e.column == col
                    && (at.is_empty() || text == at)
                    && e.message.contains(fragment)
                    && !e.message.contains("Rule")
                    && !e.message.contains("kw_")
                    && !e.message.contains("_decl");
                if !ok {
                    failures.push(format!(
                        "{what}: got {}:{} on `{text}` (want {line}:{col} on `{at}`)\n   {}\n   want: {fragment}",
                        e.line, e.column, e.message
                    ));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases().len(),
        failures.join("\n")
    );
}

#[test]
fn display_has_position_excerpt_and_caret() {
    let e = parse(&BASE.replacen("-1, th;", "-1, th2;", 1)).unwrap_err();
    let shown = e.to_string();
    assert_eq!(
        shown,
        "5:14: unknown name `th2` in an entry of A: expected a declared parameter or a number (did you mean `th`?)\n  |     A = [-1, th2; 0, -2];\n  |              ^^^"
    );
}

#[test]
fn warnings_are_positioned() {
    let src = BASE
        .replacen(
            "param th in [0, 1];",
            "param th in [0, 1]; param unused in [0, 1];",
            1,
        )
        .replacen(
            "region box(1);",
            "region vertices [1, 0; 0, 1; -1, -1; 0.1, 0.1]; state_bound Q = [0.5, 0; 0, 0.5];",
            1,
        );
    let m = parse(&src).unwrap().remove(0);
    let msgs: Vec<(&str, &str)> = m
        .warnings
        .iter()
        .map(|w| (&src[w.span.start..w.span.end], w.message.as_str()))
        .collect();
    // The base plant is LPV: its region and state bound are reported unused.
    assert_eq!(msgs.len(), 5, "{msgs:?}");
    assert!(msgs
        .iter()
        .any(|(at, msg)| at.starts_with("region vertices") && msg.contains("region is not used")));
    assert!(msgs
        .iter()
        .any(|(at, msg)| at.starts_with("state_bound") && msg.contains("state bound is not used")));
    assert!(msgs
        .iter()
        .any(|(at, msg)| *at == "0.1, 0.1" && msg.contains("vertex 4 is not a vertex")));
    assert!(msgs
        .iter()
        .any(|(at, msg)| *at == "unused" && msg.contains("appears in no matrix")));
    assert!(msgs
        .iter()
        .any(|(at, msg)| at.starts_with("state_bound") && msg.contains("xᵀQ⁻¹x = 4.0000 > 1")));
}

#[test]
fn old_mac_line_endings_give_the_right_positions() {
    // Lines ended by a lone CR (and by CRLF) count as lines: the error is
    // on line 5, with that line as its excerpt.
    let bad = BASE.replacen("-1, th;", "-1, th2;", 1);
    for ending in ["\r", "\r\n"] {
        let e = parse(&bad.replace('\n', ending)).unwrap_err();
        assert_eq!((e.line, e.column), (5, 14), "{ending:?}: {e}");
        assert_eq!(e.excerpt, "    A = [-1, th2; 0, -2];", "{ending:?}");
    }
}

#[test]
fn a_control_character_is_named_not_an_unknown_statement() {
    let e = parse(&BASE.replacen("    output y;", "\0   output y;", 1)).unwrap_err();
    assert_eq!((e.line, e.column), (3, 1), "{e}");
    assert!(e.message.contains("U+0000 (NUL)"), "{e}");
    assert!(e.message.contains("plain text"), "{e}");
}

#[test]
fn numbers_far_from_one_are_shown_in_scientific_form() {
    use qpv_dsl::diagnostic::fmt_num;
    assert_eq!(fmt_num(1e-320), "1e-320");
    assert_eq!(fmt_num(1e308), "1e308");
    assert_eq!(fmt_num(-2.5e-7), "-2.5e-7");
    assert_eq!(fmt_num(0.25), "0.25");
    assert_eq!(fmt_num(1200.0), "1200");
    assert_eq!(fmt_num(0.0), "0");
}

#[test]
fn rate_bounds_of_parameters_and_inputs_are_read() {
    let text = BASE
        .replace(
            "param th in [0, 1];",
            "param th in [0, 1] rate 2; input u1, u2 rate 10; input u3;",
        )
        .replace("C = [1, 0];", "C = [1, 0]; B = [1, 0, 0; 0, 1, 1];");
    let models = parse(&text).expect("parses");
    let m = &models[0];
    assert_eq!(m.params[0].rate, Some(2.0));
    assert_eq!(m.input_rates, vec![Some(10.0), Some(10.0), None]);
    assert_eq!(m.polytopic().input_rates, m.input_rates);
    // `rate` stays an ordinary name elsewhere
    let named = BASE.replace("output y;", "output rate;");
    assert!(parse(&named).is_ok());
}
