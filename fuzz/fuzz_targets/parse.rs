//! Feeds arbitrary bytes (as lossy UTF-8) to the parser and the REPL's completeness test:
//! neither may panic, hang or overflow the stack, whatever the input.

#![no_main]

use felt::syntax::span::FileId;
use felt::syntax::{is_incomplete, parse};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Err(errors) = parse(FileId(0), &text) {
        assert!(
            !errors.is_empty(),
            "a failed parse reports at least one error"
        );
        for error in &errors {
            let (start, end) = (error.span.start as usize, error.span.end as usize);
            assert!(
                start <= end && end <= text.len(),
                "error span inside the text"
            );
        }
    }
    let _ = is_incomplete(&text);
});
