//! The Slurm job scripts of a frame split into tiles (`strahl farm slurm`): a job array whose
//! task `I` runs `strahl render SCENE -o DIR/tile-I.exr --tile I/N --resume …`, and a merge job
//! that runs `strahl merge OUT.exr tile-1.exr … tile-N.exr` in `DIR = OUT.exr.farm/`.
//!
//! **The rule: every value reaches its job as exactly the argument given, or is refused** with
//! one line naming it, before anything is written. The scripts are read twice, by two parsers:
//!
//! - **The shell** (`#!/bin/sh`) runs the commands. Every path and option is one POSIX
//!   single-quoted word (`'…'`, a `'` written `'\''`), which carries every byte but NUL. sbatch
//!   refuses a script holding the pair `\r\n` (it takes it for DOS line ends), so that pair is
//!   written `\r''\n`: two quoted words joined, the same argument.
//! - **sbatch** reads the `#SBATCH` lines at the top, which the shell skips as comments. A
//!   line ends at a newline, and whatever follows would be a command of the shell: a value
//!   holding a newline cannot be carried. Within a line, sbatch splits words at white space
//!   unless they are in `'…'` or `"…"`, a backslash escapes the next character and an unquoted
//!   `#` starts a comment (`get_argument` in Slurm's `src/sbatch/opt.c`). The logs' paths are
//!   written `--output="…"` with `\` and `"` escaped. slurmstepd then reads that path as a
//!   pattern (`src/slurmd/common/fname.c`): `%A`, `%a`, `%j`… are replaced, `%%` is a `%`, and a
//!   backslash anywhere turns the replacing off. So a `%` of the folder is written `%%`, and an
//!   output path holding a backslash, a newline or any other control character is refused (a
//!   control character also could not be pasted from the printed submit commands: a tab
//!   completes, a carriage return or escape garbles the terminal). `--partition` and `--time`
//!   must match Slurm's own grammar for them ([`partition_problem`], [`time_problem`]), so
//!   they are written as they are.
//! - Non-UTF-8 paths and options are refused: Slurm's job records and logs are text.
//!
//! **The merge's command line stays far below `ARG_MAX`**: the merge job changes into `DIR` and
//! names the parts `tile-I.exr`, at most 15 bytes each, with at most [`MAX_TILES`] tiles:
//! under 250 KB of arguments and pointers against Linux's 2 MB, where absolute paths for
//! 100,000 tiles made 5.7 MB (`Argument list too long`).
//!
//! **Recovery.** Both jobs append to their logs (`--open-mode=append`), so a requeued task's
//! log keeps the `interrupted: N of M tiles saved` line of its first run. The merge depends on
//! the array with `afterany`: it runs once every task has ended, whatever their end, and
//! refuses a missing or incomplete tile naming it, instead of waiting forever
//! (`DependencyNeverSatisfied`) as `afterok` does after a failed task.

use std::ffi::{OsStr, OsString};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Most tiles (array tasks) of one frame: keeps the merge's command line under 250 KB.
pub const MAX_TILES: u32 = 10_000;

/// Most bytes of an output path: the logs' names must stay under Slurm's `MAXPATHLEN` (4096).
pub const MAX_OUTPUT_PATH: usize = 3_900;

/// Most bytes of the render options together (a task's command line and the script).
pub const MAX_RENDER_OPTIONS: usize = 64 * 1024;

/// What `strahl farm slurm` submits: the values every job needs, as the jobs must see them.
#[derive(Clone, Debug, Default)]
pub struct SlurmJob {
    /// The strahl the nodes run: a path, or a name found on the nodes' `PATH`.
    pub strahl: PathBuf,
    /// The scene file, absolute.
    pub scene: PathBuf,
    /// The merged EXR, absolute; the jobs' folder is this path with `.farm` appended.
    pub output: PathBuf,
    /// Number of tiles, `1..=MAX_TILES`.
    pub tiles: u32,
    /// Slurm partition(s) of both jobs.
    pub partition: Option<String>,
    /// Slurm time limit of each job.
    pub time: Option<String>,
    /// CPUs per task; each render runs as many threads.
    pub cpus: Option<u32>,
    /// `--confine DIR` for every render, absolute.
    pub confine: Option<PathBuf>,
    /// Further `strahl render` options, passed to every task as they are.
    pub render_options: Vec<OsString>,
    /// Denoise the merged frame: the merge job merges into `noisy.exr` in the jobs' folder,
    /// then runs `strahl denoise noisy.exr -o OUT.exr`, once for the whole frame.
    pub denoise: bool,
}

/// The two job scripts of a [`SlurmJob`] and the folder they go in.
#[derive(Clone, Debug)]
pub struct Scripts {
    /// `OUT.exr.farm`: the scripts, the tiles, their checkpoints and the logs.
    pub folder: PathBuf,
    /// `render.sbatch`: the job array.
    pub render: String,
    /// `merge.sbatch`: the merge.
    pub merge: String,
}

/// A value the job scripts cannot carry, named, on one line.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct FarmError(pub String);

impl Scripts {
    pub fn render_path(&self) -> PathBuf {
        self.folder.join("render.sbatch")
    }

    pub fn merge_path(&self) -> PathBuf {
        self.folder.join("merge.sbatch")
    }

    /// The shell commands that submit both scripts, the merge after the array: two lines,
    /// every path quoted, safe to paste.
    pub fn submit_commands(&self) -> String {
        // The folder passed the output's checks: UTF-8, no control character.
        let word = |p: PathBuf| shell_word(&p.to_string_lossy());
        format!(
            "id=$(sbatch --parsable {}) && \\\nsbatch --dependency=afterany:\"${{id%%;*}}\" {}\n",
            word(self.render_path()),
            word(self.merge_path())
        )
    }
}

/// The job scripts of `job`, or the first value they cannot carry (see the module docs).
pub fn slurm_scripts(job: &SlurmJob) -> Result<Scripts, FarmError> {
    let fail = |m: String| Err(FarmError(m));
    if !(1..=MAX_TILES).contains(&job.tiles) {
        return fail(format!("--tiles {}: must be from 1 to {MAX_TILES}", job.tiles));
    }
    let output = utf8(job.output.as_os_str(), "the output (-o)")?;
    if let Some(problem) = output_problem(output) {
        return fail(format!("the output (-o) {output:?}: {problem}"));
    }
    let scene = utf8(job.scene.as_os_str(), "the scene")?;
    if !job.scene.is_absolute() {
        return fail(format!("the scene {scene:?}: must be an absolute path (the jobs run elsewhere)"));
    }
    let strahl = utf8(job.strahl.as_os_str(), "--strahl")?;
    if strahl.is_empty() || strahl.starts_with('-') {
        return fail(format!("--strahl {strahl:?}: must be a path or a command name"));
    }
    let confine = match &job.confine {
        Some(dir) => {
            let d = utf8(dir.as_os_str(), "--confine")?;
            if !dir.is_absolute() {
                return fail(format!("--confine {d:?}: must be an absolute path (the jobs run elsewhere)"));
            }
            Some(d)
        }
        None => None,
    };
    if let Some(p) = &job.partition {
        if let Some(problem) = partition_problem(p) {
            return fail(format!("--partition {p:?}: {problem}"));
        }
    }
    if let Some(t) = &job.time {
        if let Some(problem) = time_problem(t) {
            return fail(format!("--time {t:?}: {problem}"));
        }
    }
    let mut options = Vec::new();
    for (k, o) in job.render_options.iter().enumerate() {
        options.push(utf8(o, &format!("the render option {} after --", k + 1))?);
    }
    if options.iter().map(|o| o.len() + 3).sum::<usize>() > MAX_RENDER_OPTIONS {
        return fail(format!("the render options after --: more than {MAX_RENDER_OPTIONS} bytes"));
    }

    let folder = format!("{output}.farm");
    let n = job.tiles;
    let header = |name: &str, log: &str| {
        let mut s = String::from("#!/bin/sh\n");
        let _ = writeln!(s, "#SBATCH --job-name={name}");
        let _ = writeln!(s, "#SBATCH --output={}", sbatch_word(&format!("{}/{log}", folder.replace('%', "%%"))));
        s.push_str("#SBATCH --open-mode=append\n");
        if let Some(p) = &job.partition {
            let _ = writeln!(s, "#SBATCH --partition={p}");
        }
        if let Some(t) = &job.time {
            let _ = writeln!(s, "#SBATCH --time={t}");
        }
        if let Some(c) = job.cpus {
            let _ = writeln!(s, "#SBATCH --cpus-per-task={c}");
        }
        s
    };

    let mut render = header("strahl-render", "render-%A_%a.log");
    let _ = writeln!(render, "#SBATCH --array=1-{n}");
    render.push_str("#SBATCH --requeue\n");
    let _ = writeln!(render, "# Task I renders tile I of {n}; --resume continues a requeued task from its checkpoint.");
    let mut line = format!(
        "exec {} render {} -o {}/tile-\"$SLURM_ARRAY_TASK_ID\".exr --tile \"$SLURM_ARRAY_TASK_ID\"/{n} --resume",
        shell_word(strahl),
        shell_word(scene),
        shell_word(&folder)
    );
    if let Some(c) = job.cpus {
        let _ = write!(line, " --threads {c}");
    }
    if let Some(d) = confine {
        let _ = write!(line, " --confine {}", shell_word(d));
    }
    for o in &options {
        line.push(' ');
        line.push_str(&shell_word(o));
    }
    render.push_str(&line);
    render.push('\n');

    let mut merge = header("strahl-merge", "merge-%j.log");
    let _ = writeln!(merge, "# Runs after every task of the render array has ended; refuses a missing tile.");
    let _ = writeln!(merge, "cd {} || exit 1", shell_word(&folder));
    let merged = if job.denoise { "noisy.exr".to_string() } else { shell_word(output) };
    let _ = write!(merge, "{}{} merge {merged}", if job.denoise { "" } else { "exec " }, shell_word(strahl));
    for i in 1..=n {
        let _ = write!(merge, " tile-{i}.exr");
    }
    if job.denoise {
        let _ = write!(merge, " || exit 1\n# The merged frame denoised once: tiles denoised apart would show seams.\n");
        let _ = write!(merge, "exec {} denoise noisy.exr -o {}", shell_word(strahl), shell_word(output));
    }
    merge.push('\n');
    Ok(Scripts { folder: PathBuf::from(folder), render, merge })
}

fn utf8<'a>(value: &'a OsStr, what: &str) -> Result<&'a str, FarmError> {
    value.to_str().ok_or_else(|| {
        FarmError(format!("{what} {:?}: is not UTF-8, which Slurm's job records and logs need", Path::new(value)))
    })
}

/// Why `output` cannot name the merged file and, with `.farm` appended, the jobs' folder in
/// an `#SBATCH --output` line (see the module docs).
fn output_problem(output: &str) -> Option<String> {
    if !Path::new(output).is_absolute() {
        return Some("must be an absolute path (the jobs run elsewhere)".into());
    }
    if !Path::new(output).extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        return Some("must have the extension .exr".into());
    }
    if let Some(c) = output.chars().find(|c| c.is_control()) {
        return Some(format!(
            "holds the control character {c:?}, which an #SBATCH line cannot carry (a newline would end it)"
        ));
    }
    if output.contains('\\') {
        return Some("holds a backslash, which turns off Slurm's log names (%A, %a) in #SBATCH --output".into());
    }
    // Each `%` is written twice in the log paths.
    if output.len() + output.matches('%').count() > MAX_OUTPUT_PATH {
        return Some(format!("is longer than {MAX_OUTPUT_PATH} bytes (Slurm's log paths stop at 4096)"));
    }
    None
}

/// Why `p` is not a Slurm partition list: names of letters, digits, `.`, `_`, `-` and `+`,
/// separated by commas (`--partition=a,b`), 1024 bytes at most (slurmctld's limit).
pub fn partition_problem(p: &str) -> Option<&'static str> {
    let name_ok = |n: &str| !n.is_empty() && n.chars().all(|c| c.is_ascii_alphanumeric() || "._-+".contains(c));
    if p.len() > 1024 {
        Some("is longer than Slurm's 1024 bytes")
    } else if !p.split(',').all(name_ok) {
        Some("is not a Slurm partition name (letters, digits, '.', '_', '-', '+'; several separated by commas)")
    } else {
        None
    }
}

/// Why `t` is not a Slurm time limit: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S` (digits),
/// `INFINITE` or `UNLIMITED` (sbatch's formats).
pub fn time_problem(t: &str) -> Option<&'static str> {
    if t.eq_ignore_ascii_case("infinite") || t.eq_ignore_ascii_case("unlimited") {
        return None;
    }
    let number = |s: &str| (1..=9).contains(&s.len()) && s.bytes().all(|b| b.is_ascii_digit());
    let (days, clock) = match t.split_once('-') {
        Some((d, rest)) => (Some(d), rest),
        None => (None, t),
    };
    let fields: Vec<&str> = clock.split(':').collect();
    if days.is_none_or(number) && fields.len() <= 3 && fields.iter().all(|f| number(f)) {
        None
    } else {
        Some("is not a Slurm time limit (M, M:S, H:M:S, D-H, D-H:M, D-H:M:S, INFINITE)")
    }
}

/// `s` as one POSIX shell word: single quotes, a `'` as `'\''`, and the pair `\r\n` split
/// as `\r''\n` (sbatch refuses a script holding it).
fn shell_word(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''").replace("\r\n", "\r''\n"))
}

/// `s` as one word of an `#SBATCH` line: in double quotes, `\` and `"` escaped with a
/// backslash (sbatch's `get_argument`). It must hold no newline, which ends the line.
fn sbatch_word(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        if c == '\\' || c == '"' {
            out.push('\\');
        }
        out.push(c);
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job() -> SlurmJob {
        SlurmJob {
            strahl: "/opt/strahl".into(),
            scene: "/s/scene.toml".into(),
            output: "/o/frame.exr".into(),
            tiles: 4,
            ..Default::default()
        }
    }

    #[test]
    fn slurm_time_formats() {
        for ok in ["30", "30:00", "1:00:00", "2-0", "2-12:30", "1-00:00:00", "UNLIMITED", "infinite"] {
            assert_eq!(time_problem(ok), None, "{ok}");
        }
        for bad in ["", "1:00\ntouch PWNED", "1:2:3:4", "-1", "1-", "a", "1-2-3", "1 :00", "1:00;x", "1234567890"] {
            assert!(time_problem(bad).is_some(), "{bad:?}");
        }
    }

    #[test]
    fn partition_names() {
        for ok in ["render", "gpu_a100", "a,b", "long-2.x+"] {
            assert_eq!(partition_problem(ok), None, "{ok}");
        }
        for bad in ["", "p\ntouch PWNED", "a,,b", "a b", "p#x", "p'", "$(x)", "ш"] {
            assert!(partition_problem(bad).is_some(), "{bad:?}");
        }
    }

    #[test]
    fn the_log_folder_is_an_sbatch_word_with_percent_signs_doubled() {
        let mut j = job();
        j.output = "/o/50% \"it's\" #1.exr".into();
        let s = slurm_scripts(&j).unwrap();
        assert!(
            s.render.contains("#SBATCH --output=\"/o/50%% \\\"it's\\\" #1.exr.farm/render-%A_%a.log\"\n"),
            "{}",
            s.render
        );
        assert!(s.merge.contains("cd '/o/50% \"it'\\''s\" #1.exr.farm' || exit 1\n"), "{}", s.merge);
    }

    #[test]
    fn a_carriage_return_line_feed_pair_is_split_between_two_quoted_words() {
        assert_eq!(shell_word("a\r\nb'c"), "'a\r''\nb'\\''c'");
        let mut j = job();
        j.render_options = vec!["x\r\ny".into()];
        assert!(!slurm_scripts(&j).unwrap().render.contains("\r\n"));
    }
}
