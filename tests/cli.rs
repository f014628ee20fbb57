//! End-to-end tests of the `plotter` binary.

use plotter_e2e::sample;

#[test]
fn samples_exist() {
    assert!(sample("xy-plotter.toml").is_file());
}
