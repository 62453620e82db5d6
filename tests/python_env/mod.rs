//! A python3 that imports the packages the Python examples use, at the versions examples/README.md
//! pins: the python3 on PATH when it already has them, otherwise a virtual environment that the
//! tests build once under cargo's target directory (`target/tmp/py-venv`) and reuse.
//!
//! Several test processes may start at the same time on a fresh target directory, so every
//! environment is built under a private name and renamed into place; the first rename wins and
//! the others discard their copy. A venv survives the rename because its interpreter finds
//! `pyvenv.cfg` next to itself, and the tests only ever run `bin/python`.
//!
//! When python3 has no `venv` with `ensurepip` (Debian without `python3-venv`), python3's own pip
//! installs the packages into `target/tmp/py-site`, which goes on PYTHONPATH. When neither works,
//! or PyPI cannot be reached, the error is one line saying what to install.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{SystemTime, UNIX_EPOCH};

/// The pinned requirements of the examples (examples/README.md), as pip takes them.
pub const PACKAGES: [&str; 2] = ["eclipse-zenoh==1.10.2", "iceoryx2==0.10.0"];

/// Imports the modules the examples import and checks each pinned distribution's version; exits
/// non-zero with the reason on stderr.
const CHECK_PACKAGES: &str = r#"
import importlib.metadata, sys
import iceoryx2, zenoh
for spec in sys.argv[1:]:
    name, wanted = spec.split("==")
    found = importlib.metadata.version(name)
    if found != wanted:
        sys.exit(f"{name} {found} is installed, {wanted} is needed")
"#;

/// How to run a python3 that has the packages.
#[derive(Clone, Debug)]
pub struct Python {
    program: PathBuf,
    pythonpath: Option<PathBuf>,
    /// Where the packages come from, for the test log.
    pub origin: String,
}

impl Python {
    /// A command running this interpreter (with its PYTHONPATH, if it needs one).
    pub fn command(&self) -> Command {
        let mut cmd = Command::new(&self.program);
        if let Some(dir) = &self.pythonpath {
            let mut path = OsString::from(dir);
            if let Some(old) = std::env::var_os("PYTHONPATH").filter(|p| !p.is_empty()) {
                path.push(":");
                path.push(old);
            }
            cmd.env("PYTHONPATH", path);
        }
        cmd
    }

    /// Ok when the interpreter imports both packages at the pinned versions, else the reason.
    fn check(&self) -> Result<(), String> {
        let out = self
            .command()
            .args(["-c", CHECK_PACKAGES])
            .args(PACKAGES)
            .output()
            .map_err(|e| format!("cannot run {}: {e}", self.program.display()))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(last_line(&out))
        }
    }
}

/// The python3 on PATH when it has the packages, else the environment under `target/tmp`, built
/// on first use. Err is a one-line message naming what to install.
pub fn python_with_packages() -> Result<Python, String> {
    let system = Python {
        program: "python3".into(),
        pythonpath: None,
        origin: "python3 on PATH".into(),
    };
    let missing = match system.check() {
        Ok(()) => return Ok(system),
        Err(reason) if reason.starts_with("cannot run") => {
            return Err(format!(
                "{reason}; the Python examples test needs python3 (3.8 or newer) on PATH"
            ))
        }
        Err(reason) => reason,
    };
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"));
    let (venv, site) = (venv_python(&dir.join("py-venv")), site_python(dir));
    for ready in [&venv, &site] {
        if ready.check().is_ok() {
            return Ok(ready.clone());
        }
    }
    eprintln!(
        "python3 lacks the examples' packages ({missing}); installing {} from PyPI into {}",
        PACKAGES.join(" "),
        dir.display()
    );
    match build_venv(dir) {
        Ok(()) => settle(&venv),
        Err(VenvError::NoVenv(why)) => {
            build_site(dir, &why)?;
            settle(&site)
        }
        Err(VenvError::Install(why)) => Err(why),
    }
}

fn venv_python(venv: &Path) -> Python {
    Python {
        program: venv.join("bin").join("python"),
        pythonpath: None,
        origin: format!("virtual environment {}", venv.display()),
    }
}

fn site_python(dir: &Path) -> Python {
    let site = dir.join("py-site");
    Python {
        program: "python3".into(),
        origin: format!("python3 with PYTHONPATH={}", site.display()),
        pythonpath: Some(site),
    }
}

/// The environment that was just renamed into place (by this process or a faster one) must work.
fn settle(python: &Python) -> Result<Python, String> {
    python
        .check()
        .map(|()| python.clone())
        .map_err(|e| format!("{} cannot import the packages: {e}", python.origin))
}

enum VenvError {
    /// python3 cannot make a venv with pip (no venv module or no ensurepip).
    NoVenv(String),
    /// The venv exists but pip failed (usually: no network).
    Install(String),
}

/// `python3 -m venv`, pip install into it, rename to `py-venv`.
fn build_venv(dir: &Path) -> Result<(), VenvError> {
    let staging = staging_dir(dir, "py-venv");
    let made = run(Command::new("python3").arg("-m").arg("venv").arg(&staging));
    if let Err(why) = made {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(VenvError::NoVenv(why));
    }
    let mut pip = venv_python(&staging).command();
    pip.args(["-m", "pip", "install"]);
    pip_install(&mut pip).map_err(|why| {
        let _ = std::fs::remove_dir_all(&staging);
        VenvError::Install(why)
    })?;
    let target = dir.join("py-venv");
    move_into_place(&staging, &target, &venv_python(&target));
    Ok(())
}

/// `python3 -m pip install --target`, rename to `py-site` (the fallback without venv).
fn build_site(dir: &Path, no_venv: &str) -> Result<(), String> {
    let staging = staging_dir(dir, "py-site");
    let mut pip = Command::new("python3");
    pip.args(["-m", "pip", "install", "--target"]).arg(&staging);
    // pip's own "No module named pip" when python3 has no pip either.
    let result = pip_install(&mut pip).map_err(|why| {
        if why.contains("No module named pip") {
            format!(
                "python3 can neither make a virtual environment ({no_venv}) nor run pip: install \
                 python3-venv (Debian/Ubuntu) or pip, or the packages: python3 -m pip install {}",
                PACKAGES.join(" ")
            )
        } else {
            why
        }
    });
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    result?;
    move_into_place(&staging, &dir.join("py-site"), &site_python(dir));
    Ok(())
}

/// Runs a prepared `pip install` command with the pinned packages, quietly.
fn pip_install(pip: &mut Command) -> Result<(), String> {
    pip.args(["--quiet", "--disable-pip-version-check", "--no-input"])
        .args(["--retries", "2", "--timeout", "30"])
        .args(PACKAGES)
        .env("PIP_ROOT_USER_ACTION", "ignore");
    run(pip).map_err(|why| {
        format!(
            "pip could not install {} from PyPI ({why}); without network access install them \
             into python3 yourself: python3 -m pip install {}",
            PACKAGES.join(" "),
            PACKAGES.join(" ")
        )
    })
}

/// A directory name no other process uses: `<name>.partial-<pid>-<ns>`.
fn staging_dir(dir: &Path, name: &str) -> PathBuf {
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    dir.join(format!("{name}.partial-{}-{nanos}", std::process::id()))
}

/// Renames `staging` to `target`, where `installed` will look for the packages. When `target`
/// exists already it is either a good environment another test process has just finished (kept,
/// ours dropped) or a broken one left from before (set aside and removed, ours put in place).
fn move_into_place(staging: &Path, target: &Path, installed: &Python) {
    if std::fs::rename(staging, target).is_ok() {
        return;
    }
    if installed.check().is_ok() {
        let _ = std::fs::remove_dir_all(staging);
        return;
    }
    let aside = PathBuf::from(format!("{}.stale", staging.display()));
    if std::fs::rename(target, &aside).is_ok() {
        let _ = std::fs::remove_dir_all(&aside);
    }
    if std::fs::rename(staging, target).is_err() {
        let _ = std::fs::remove_dir_all(staging);
    }
}

/// Runs `cmd`; Err holds the last line it printed on stderr (or how it could not start).
fn run(cmd: &mut Command) -> Result<(), String> {
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run {:?}: {e}", cmd.get_program()))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(last_line(&out))
    }
}

/// The last non-empty line of stderr (stdout if stderr is empty): the reason Python gives.
fn last_line(out: &Output) -> String {
    let text = |b: &[u8]| String::from_utf8_lossy(b).trim().to_string();
    let (err, std) = (text(&out.stderr), text(&out.stdout));
    let all = if err.is_empty() { std } else { err };
    all.lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("no output")
        .trim()
        .to_string()
}
