//! The command line of the Rust examples: the options all of them take (`--instance`,
//! `--vessel`, `--count`, as the Python examples do) and the flags of each one, every flag
//! with a value.

use std::process::ExitCode;

// The binary's own: errors as one line, without the source locations zenoh writes into them.
#[path = "../../services/error_text.rs"]
mod error_text;

pub struct Options {
    pub instance: String,
    pub vessel: String,
    /// Stop after this many messages; 0 runs until the process is stopped.
    pub count: usize,
    /// The example's own flags that were given, with their values.
    own: Vec<(String, String)>,
}

impl Options {
    /// The value of one of the example's own flags (the last one given), if given.
    // Not every example has flags of its own; each compiles this file on its own.
    #[allow(dead_code)]
    pub fn get(&self, flag: &str) -> Option<&str> {
        self.own
            .iter()
            .rev()
            .find(|(f, _)| f == flag)
            .map(|(_, v)| v.as_str())
    }
}

/// Parse the process's arguments; `own` names the example's own flags, in the order its
/// usage lists them, before the common ones.
pub fn parse(own: &[&str]) -> Result<Options, String> {
    let mut options = Options {
        instance: String::new(),
        vessel: "ddg51".into(),
        count: 0,
        own: Vec::new(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--instance" => options.instance = value()?,
            "--vessel" => options.vessel = value()?,
            "--count" => {
                let v = value()?;
                options.count = v
                    .parse()
                    .map_err(|_| format!("--count must be a whole number, got '{v}'"))?;
            }
            f if own.contains(&f) => {
                let v = value()?;
                options.own.push((flag, v));
            }
            other => {
                return Err(format!("unknown option '{other}' ({})", usage(own)));
            }
        }
    }
    // The rule every shipcast name keeps (docs/contracts.md): a name that breaks it names no
    // service the pipeline has, and iceoryx2's own refusal does not say which option it was.
    if !options.instance.is_empty() {
        check_name("--instance", &options.instance)?;
    }
    check_name("--vessel", &options.vessel)?;
    Ok(options)
}

/// Longest name segment shipcast accepts.
const MAX_NAME: usize = 64;

fn check_name(flag: &str, name: &str) -> Result<(), String> {
    let allowed = |c: char| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-');
    if name.is_empty() || name.len() > MAX_NAME || !name.chars().all(allowed) {
        return Err(format!(
            "{flag} '{name}': 1 to {MAX_NAME} characters of A-Z a-z 0-9 . _ -"
        ));
    }
    Ok(())
}

/// The options an example takes, for `--help` and the error for an unknown one.
fn usage(own: &[&str]) -> String {
    own.iter()
        .map(|f| format!("{f} VALUE"))
        .chain([
            "--instance NAME".to_string(),
            "--vessel NAME".to_string(),
            "--count N".to_string(),
        ])
        .collect::<Vec<_>>()
        .join(", ")
}

/// An example's `main`: parse the command line with the example's own flags `own`, run it,
/// and turn an error into one line on stderr and a failing exit code.
pub fn main_with<E: std::fmt::Display>(
    own: &[&str],
    run: impl FnOnce(&Options) -> Result<(), E>,
) -> ExitCode {
    if std::env::args().skip(1).any(|a| a == "--help" || a == "-h") {
        println!("options: {} (see the example's source header)", usage(own));
        return ExitCode::SUCCESS;
    }
    let result = match parse(own) {
        Ok(options) => run(&options).map_err(|e| e.to_string()),
        Err(e) => Err(e),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_text::one_line(&e));
            ExitCode::FAILURE
        }
    }
}
