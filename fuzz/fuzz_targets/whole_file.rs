#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| subwave::fuzz_harness::whole_file(data));
