//! Link with cortex-m-rt's script (`memory.x` and `device.x` come from the `lm3s6965` device crate).
fn main() {
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rerun-if-changed=build.rs");
}
