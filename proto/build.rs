//! Generates the worker service from `ridgeline/v1/worker.proto`. A vendored `protoc`
//! is used unless `PROTOC` is set, so a fresh machine needs nothing installed.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    if std::env::var_os("PROTOC").is_none() {
        // SAFETY: build scripts are single-threaded; nothing reads the environment concurrently.
        unsafe { std::env::set_var("PROTOC", protoc_bin_vendored::protoc_bin_path()?) };
    }
    println!("cargo:rerun-if-changed=ridgeline/v1/worker.proto");
    tonic_prost_build::configure().compile_protos(&["ridgeline/v1/worker.proto"], &["."])?;
    Ok(())
}
