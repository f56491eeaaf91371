//! The names of the report's vocabulary: every condition family and search
//! phase round-trips through serde under its name, state bound sources
//! through `from_name`, and unknown names are refused.

use qpv_solve::vocab::{BoundSource, Family, Phase};

#[test]
fn every_name_round_trips_through_serde() {
    for f in Family::ALL {
        let json = serde_json::to_string(f).unwrap();
        assert_eq!(json, format!("\"{}\"", f.name()));
        assert_eq!(serde_json::from_str::<Family>(&json).unwrap(), *f);
    }
    for p in Phase::ALL {
        let json = serde_json::to_string(p).unwrap();
        assert_eq!(json, format!("\"{p}\""));
        assert_eq!(serde_json::from_str::<Phase>(&json).unwrap(), *p);
    }
    for b in BoundSource::ALL {
        assert_eq!(BoundSource::from_name(b.name()), Some(*b));
    }
    assert!(serde_json::from_str::<Phase>("\"polish\"").is_err());
    assert_eq!(Phase::FinalBisect, "final-bisect");
    assert_eq!(Family::Paper26.to_string(), "26");
}
