//! The command line of the Rust examples: the options all of them take (`--instance`,
//! `--vessel`, `--count`, as the Python examples do) and the flags of each one, every flag
//! with a value.

use std::process::ExitCode;

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
                let known: Vec<&str> = own
                    .iter()
                    .copied()
                    .chain(["--instance", "--vessel", "--count"])
                    .collect();
                return Err(format!("unknown option '{other}' ({})", known.join(", ")));
            }
        }
    }
    Ok(options)
}

/// An example's `main`: parse the command line with the example's own flags `own`, run it,
/// and turn an error into one line on stderr and a failing exit code.
pub fn main_with<E: std::fmt::Display>(
    own: &[&str],
    run: impl FnOnce(&Options) -> Result<(), E>,
) -> ExitCode {
    let result = match parse(own) {
        Ok(options) => run(&options).map_err(|e| e.to_string()),
        Err(e) => Err(e),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
