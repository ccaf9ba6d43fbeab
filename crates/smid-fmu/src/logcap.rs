//! Capture of the messages an FMU sends to its logger callback. The `fmi` crate forwards them to
//! the `log` crate (module path `logger`, target = instance name); this module installs, once, a
//! `log` logger that keeps the last messages of the current thread so that an error can quote
//! what the FMU said. Other records are passed on to standard error at warning level and above.
//! If the application installed its own logger first, FMU messages go there instead and errors
//! carry no FMU log.
use std::cell::RefCell;
use std::sync::Once;

const KEEP: usize = 20;

thread_local! {
    static MESSAGES: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) };
}

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, metadata: &log::Metadata) -> bool {
        metadata.level() <= log::Level::Warn || metadata.target().starts_with("smid")
    }
    fn log(&self, record: &log::Record) {
        if record.module_path() == Some("logger") {
            let line = format!("[{}] {}", record.level(), record.args());
            MESSAGES.with(|m| {
                let mut m = m.borrow_mut();
                if m.len() >= KEEP {
                    m.remove(0);
                }
                m.push(line);
            });
        } else if record.level() <= log::Level::Warn {
            eprintln!("{}: {}", record.level(), record.args());
        }
    }
    fn flush(&self) {}
}

static CAPTURE: Capture = Capture;
static INSTALL: Once = Once::new();

/// Install the capturing logger (idempotent).
pub fn install() {
    INSTALL.call_once(|| {
        // FMU messages bypass the level filter (the callback calls the logger directly); the
        // filter only governs the fmi crate's own messages, of which warnings are shown.
        if log::set_logger(&CAPTURE).is_ok() && log::max_level() < log::LevelFilter::Warn {
            log::set_max_level(log::LevelFilter::Warn);
        }
    });
}

/// Forget the messages captured so far on this thread.
pub fn clear() {
    MESSAGES.with(|m| m.borrow_mut().clear());
}

/// Take the messages captured on this thread.
pub fn take() -> Vec<String> {
    MESSAGES.with(|m| std::mem::take(&mut *m.borrow_mut()))
}
