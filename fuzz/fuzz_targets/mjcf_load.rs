//! Arbitrary bytes into the MJCF loader: it must return a model or a typed error, never
//! panic; a loaded model holds only finite numbers (checked through its `Debug` form).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(xml) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(model) = constraint_mjcf::load_str(xml) {
        let s = format!("{model:?}");
        // Floats print as `NaN`/`inf`; names are quoted, so skip quoted text.
        let mut in_str = false;
        let mut prev = ' ';
        let mut tok = String::new();
        for c in s.chars() {
            if c == '"' && prev != '\\' {
                in_str = !in_str;
                tok.clear();
            } else if !in_str {
                if c.is_ascii_alphanumeric() || c == '_' || c == '.' {
                    tok.push(c);
                } else {
                    assert!(
                        tok != "NaN" && tok != "inf",
                        "non-finite number in a loaded model"
                    );
                    tok.clear();
                }
            }
            prev = c;
        }
    }
});
