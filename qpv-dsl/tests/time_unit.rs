//! `time = UNIT;`: the model's unit of time reaches the model and its
//! polytopic form, seconds by default, and `time` stays a usable name.

use qpv_dsl::{parse, TimeUnit};

const BASE: &str = "model m {
    state x1, x2;
    output y;
    der x1 = -x1 + x2;
    der x2 = -2*x2 + x1*x2;
    out y = x1;
    region box(1);
}";

#[test]
fn the_declared_unit_reaches_the_polytopic_model_and_seconds_are_the_default() {
    let m = &parse(BASE).unwrap()[0];
    assert_eq!(m.time_unit, TimeUnit::Seconds);
    for (word, unit) in [
        ("hours", TimeUnit::Hours),
        ("h", TimeUnit::Hours),
        ("day", TimeUnit::Days),
        ("min", TimeUnit::Minutes),
        ("ms", TimeUnit::Milliseconds),
        ("seconds", TimeUnit::Seconds),
    ] {
        let src = BASE.replace("region box(1);", &format!("region box(1); time = {word};"));
        let m = &parse(&src).unwrap_or_else(|e| panic!("{word}: {e}"))[0];
        assert_eq!(m.time_unit, unit, "{word}");
        assert_eq!(m.polytopic().time_unit, unit, "{word}");
    }
}

#[test]
fn time_is_still_a_name_where_it_is_not_a_declaration() {
    let src = "model m {
    state time, x2;
    output y;
    der time = -time + x2;
    der x2 = -2*x2;
    out y = time;
    region box(1);
    time = days;
}";
    let m = &parse(src).unwrap_or_else(|e| panic!("{e}"))[0];
    assert_eq!(m.states, ["time", "x2"]);
    assert_eq!(m.time_unit, TimeUnit::Days);
}
