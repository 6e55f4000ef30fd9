//! A caught panic's message, for the places that turn a panic into an error line instead of
//! a crash (workers, background jobs, tract's graph runs, the top-level handler).

/// The text a panic was raised with, if it carried one (`panic!` gives a `String` or a
/// `&'static str`).
pub fn panic_text(payload: &(dyn std::any::Any + Send)) -> Option<&str> {
    payload
        .downcast_ref::<String>()
        .map(String::as_str)
        .or_else(|| payload.downcast_ref::<&str>().copied())
}

/// [`panic_text`] on one line, for an error message; `"no message"` when it has none.
pub fn panic_line(payload: &(dyn std::any::Any + Send)) -> String {
    panic_text(payload)
        .unwrap_or("no message")
        .replace('\n', " ")
}
