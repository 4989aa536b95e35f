//! Fuzz target: the xyz parser must return Ok or Err on any input — never panic, never allocate beyond what the
//! input can hold (libFuzzer's -rss_limit_mb catches that).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = meniscus::scene::parse_raw(meniscus::scene::Format::Xyz, std::path::Path::new("fuzz-input"), data);
});
