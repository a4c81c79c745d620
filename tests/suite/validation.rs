//! The reduced validation (`haze validate --quick`): every analytic case, with both volume
//! estimators, both medium kinds and the path tracer, agrees with its reference by a t-test at
//! significance 10⁻³ after its stated bias bound (see `haze::validate`).

use std::path::Path;

#[test]
fn quick_validation_passes_every_case() {
    let media = Path::new(env!("CARGO_MANIFEST_DIR")).join("media");
    let rows = haze::validate::run(&media, haze::validate::Effort::QUICK, |_, _| {}).unwrap();
    assert_eq!(rows.len(), 24);
    let failed: Vec<String> = rows
        .iter()
        .filter(|r| !r.pass())
        .map(|r| format!("{} / {} / {}: {} vs {}", r.case, r.medium, r.method, r.mean, r.reference))
        .collect();
    assert!(failed.is_empty(), "{}", failed.join("\n"));
    assert!(haze::validate::markdown(&rows).contains("| pass |"));
    assert_eq!(haze::validate::csv(&rows).lines().count(), 25);
}
