//! Fuzz target: every registered particle parser must return Ok or Err on any input — never panic, never
//! allocate beyond what the input can hold (libFuzzer's -rss_limit_mb catches that). The first byte picks the
//! format from the registry (`meniscus::scene::FORMATS`), the rest is the file.
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Some((&k, file)) = data.split_first() {
        let formats = meniscus::scene::FORMATS;
        let f = formats[k as usize % formats.len()];
        let _ = f.parse(std::path::Path::new("fuzz-input"), file);
    }
});
