//! The process-wide interrupt, raised: in a test binary of its own, so that no other test sees it.

use plotter_path::config::interrupt;

#[test]
fn a_raised_interrupt_is_seen_and_names_the_work() {
    assert!(!interrupt::raised());
    interrupt::raise_if(true);
    assert!(interrupt::raised());
    let e = interrupt::check(|| "reading a.gcode".into()).unwrap_err();
    assert_eq!(e.to_string(), "interrupted while reading a.gcode");
}
