//! The end-to-end tests of the plotter workspace, in one test binary (`e2e`): each module is one test file of
//! this folder, and its name selects its tests, e.g. `cargo test -p plotter-e2e --test e2e plot_pty::`.
//!
//! One binary, not one per file: each test binary links the whole host (plotter-cli with its web server, SQLite and
//! image codecs), so one binary is linked once instead of once per file, and its tests, which mostly wait on
//! simulators, emulators and a browser, run side by side on the test threads instead of one file after another.
//! Tests therefore share this process: each takes its own scratch folder ([`plotter_e2e::scratch`]) and loopback
//! ports from the system (`127.0.0.1:0`), never the working directory or the environment; what must not overlap
//! holds a lock named where it is declared. `studio_load.rs`, which times the studio's answers under load, is a test
//! binary of its own (cargo runs one test binary after another), so that it has the machine to itself.

mod browser;
mod import_layers;
mod journal_dir;
mod layout_machine;
mod link_faults;
mod manual_commands;
mod output_formats;
mod pause_key;
mod pen_contact;
mod piped_plot;
mod plot_ebb;
mod plot_grbl;
mod plot_hpgl;
mod plot_inputs;
mod plot_pty;
mod plot_qemu;
mod plot_servo;
mod plot_time;
mod power_loss;
mod print_slicer;
mod profile_limits;
mod readme_tour;
mod samples;
mod serve_browser;
mod serve_firmware;
mod serve_limits;
mod stats_wording;
mod stop_signals;
mod stream_hpgl;
mod studio_browser;
mod studio_crash;
mod studio_three;
