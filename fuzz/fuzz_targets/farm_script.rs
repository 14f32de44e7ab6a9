//! `strahl farm slurm`'s job scripts ([`strahl::farm::slurm_scripts`]) from arbitrary values.
//! A refusal must be one line. A script that is written must pass `bash -n`; its `#SBATCH`
//! lines, read as sbatch reads them (`get_argument` in Slurm's src/sbatch/opt.c, modelled
//! below), must be exactly the options meant; run with bash, the render task and the merge
//! must hand a recorder standing in for strahl exactly the arguments given, print nothing on
//! stderr and leave no file; and the printed submit commands, run with bash, must hand a
//! recorder standing in for sbatch exactly the two scripts. Any other execution is a finding.
//!
//! The input: tiles and CPUs in the first byte, then NUL-separated fields: the output's name,
//! the scene, the name of the folder holding strahl, the partition, the time, the confine
//! folder and the render options.
#![no_main]
use std::ffi::{OsStr, OsString};
use std::os::unix::ffi::OsStringExt;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use strahl::farm::{SlurmJob, slurm_scripts};

const RECORDER: &str = "#!/bin/bash\nprintf '%s\\0' \"$#\" \"$PWD\" \"$@\" >> \"$RECORD\"\n";
const SBATCH: &str = "#!/bin/bash\nprintf '%s\\0' \"$#\" \"$PWD\" \"$@\" >> \"$RECORD\"\necho 42\n";

/// This process's scratch folder, with the sbatch recorder in bin/.
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("strahl-fuzz-farm-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("bin")).unwrap();
        write_executable(&dir.join("bin/sbatch"), SBATCH);
        dir
    })
}

fn write_executable(path: &Path, text: &str) {
    std::fs::write(path, text).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
}

/// `name` as one file name: no `/`, never empty, `.` or `..`.
fn file_name(name: &[u8]) -> OsString {
    let mut v: Vec<u8> = name.iter().copied().filter(|&b| b != b'/').collect();
    v.insert(0, b'n');
    OsString::from_vec(v)
}

fn absolute(field: &[u8]) -> PathBuf {
    let mut v = vec![b'/'];
    v.extend(field);
    PathBuf::from(OsString::from_vec(v))
}

/// The words of the script's `#SBATCH` lines, split as sbatch's `get_argument` splits them:
/// white space separates words outside '…' and "…", a backslash takes the next character, an
/// unquoted `#` or a word that copies nothing ends the line; the directives end at the first
/// line that is not a comment. `None` for what sbatch refuses (an unmatched quote, a `:`).
fn sbatch_directives(script: &[u8]) -> Option<Vec<Vec<u8>>> {
    let space = |c: u8| b" \t\n\x0b\x0c\r".contains(&c);
    let mut words = Vec::new();
    for line in script.split(|&b| b == b'\n') {
        let Some(rest) = line.strip_prefix(b"#SBATCH") else {
            match line.iter().find(|&&c| !space(c)) {
                Some(b'#') | None => continue,
                Some(_) => break,
            }
        };
        let mut i = 0;
        loop {
            while i < rest.len() && space(rest[i]) {
                i += 1;
            }
            if i >= rest.len() {
                break;
            }
            if rest[i] == b':' {
                return None;
            }
            let (mut word, mut copied, mut quote, mut escape) = (Vec::new(), false, None, false);
            while i < rest.len() && (quote.is_some() || !space(rest[i])) {
                let c = rest[i];
                if escape {
                    escape = false;
                } else if c == b'\\' {
                    i += 1;
                    if rest.get(i) == Some(&b' ') {
                        word.push(b' ');
                        copied = true;
                        i += 1;
                    } else {
                        escape = true;
                    }
                    continue;
                } else if let Some(q) = quote {
                    if c == q {
                        quote = None;
                        i += 1;
                        continue;
                    }
                } else if c == b'"' || c == b'\'' {
                    quote = Some(c);
                    i += 1;
                    continue;
                } else if c == b'#' {
                    break;
                }
                word.push(c);
                copied = true;
                i += 1;
            }
            if quote.is_some() {
                return None;
            }
            if !copied {
                break;
            }
            words.push(word);
        }
    }
    Some(words)
}

/// Runs `bash ARGS` in `cwd` with only `bin` on PATH and `RECORD=record`; returns the
/// recorded calls (count, working directory, arguments) and asserts a clean run.
fn run_bash(args: &[&OsStr], cwd: &Path, record: &Path, what: &str) -> Vec<Vec<OsString>> {
    let _ = std::fs::remove_file(record);
    // By its path: PATH holds only the sbatch recorder.
    let o = Command::new("/bin/bash")
        .args(args)
        .current_dir(cwd)
        .env_clear()
        .env("PATH", scratch().join("bin"))
        .env("RECORD", record)
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env("SLURM_ARRAY_JOB_ID", "7")
        .env("SLURM_JOB_ID", "7")
        .output()
        .unwrap();
    assert!(o.status.success() && o.stderr.is_empty(), "{what}: {o:?}");
    let bytes = std::fs::read(record).unwrap_or_default();
    let mut fields = bytes.split(|&b| b == 0).map(|f| OsString::from_vec(f.to_vec()));
    let mut calls = Vec::new();
    while let Some(count) = fields.next() {
        let Ok(n) = count.to_string_lossy().parse::<usize>() else { break };
        calls.push(fields.by_ref().take(n + 1).collect());
    }
    calls
}

fn os(s: impl AsRef<OsStr>) -> OsString {
    s.as_ref().to_os_string()
}

fuzz_target!(|data: &[u8]| {
    let Some((&first, rest)) = data.split_first() else { return };
    let fields: Vec<&[u8]> = rest.split(|&b| b == 0).collect();
    let field = |i: usize| fields.get(i).copied().unwrap_or_default();
    let present = |i: usize| fields.get(i).is_some_and(|f| !f.is_empty());
    let run = scratch().join("run");
    let _ = std::fs::remove_dir_all(&run);
    std::fs::create_dir_all(run.join("cwd")).unwrap();
    let mut output = run.join(file_name(field(0))).into_os_string();
    output.push(".exr");
    let strahl = run.join(file_name(field(2))).join("strahl");
    let job = SlurmJob {
        strahl: strahl.clone(),
        scene: absolute(field(1)),
        output: PathBuf::from(output),
        tiles: 1 + u32::from(first % 3),
        partition: present(3).then(|| String::from_utf8_lossy(field(3)).into_owned()),
        time: present(4).then(|| String::from_utf8_lossy(field(4)).into_owned()),
        cpus: Some(u32::from(first >> 2 & 7)).filter(|&c| c > 0),
        confine: present(5).then(|| absolute(field(5))),
        render_options: fields.iter().skip(6).map(|f| OsString::from_vec(f.to_vec())).collect(),
        denoise: false,
    };
    let scripts = match slurm_scripts(&job) {
        Ok(s) => s,
        Err(e) => {
            assert!(!e.to_string().contains('\n'), "a refusal of more than one line: {e}");
            return;
        }
    };
    std::fs::create_dir_all(&scripts.folder).unwrap();
    std::fs::create_dir_all(strahl.parent().unwrap()).unwrap();
    write_executable(&strahl, RECORDER);
    let (render_path, merge_path) = (scripts.render_path(), scripts.merge_path());
    std::fs::write(&render_path, &scripts.render).unwrap();
    std::fs::write(&merge_path, &scripts.merge).unwrap();
    let record = run.join("record");
    let cwd = run.join("cwd");
    let n = job.tiles;

    // sbatch's view: the options meant, nothing else.
    let folder = scripts.folder.to_str().unwrap().replace('%', "%%");
    let mut header = vec![format!("--job-name=strahl-render"), format!("--output={folder}/render-%A_%a.log")];
    header.push("--open-mode=append".into());
    header.extend(job.partition.iter().map(|p| format!("--partition={p}")));
    header.extend(job.time.iter().map(|t| format!("--time={t}")));
    header.extend(job.cpus.iter().map(|c| format!("--cpus-per-task={c}")));
    let mut render_header = header.clone();
    render_header.extend([format!("--array=1-{n}"), "--requeue".into()]);
    let as_bytes = |v: Vec<String>| v.into_iter().map(String::into_bytes).collect::<Vec<_>>();
    assert_eq!(sbatch_directives(scripts.render.as_bytes()), Some(as_bytes(render_header)), "{}", scripts.render);
    header[0] = "--job-name=strahl-merge".into();
    header[1] = format!("--output={folder}/merge-%j.log");
    assert_eq!(sbatch_directives(scripts.merge.as_bytes()), Some(as_bytes(header)), "{}", scripts.merge);
    assert!(!scripts.render.contains("\r\n") && !scripts.merge.contains("\r\n"));

    // The shell's view.
    for script in [&render_path, &merge_path] {
        let o = Command::new("bash").arg("-n").arg(script).output().unwrap();
        assert!(o.status.success(), "bash -n: {o:?}");
    }
    let mut render = vec![os(&cwd), os("render"), os(&job.scene), os("-o"), os(scripts.folder.join("tile-1.exr"))];
    render.extend([os("--tile"), os(format!("1/{n}")), os("--resume")]);
    if let Some(c) = job.cpus {
        render.extend([os("--threads"), os(c.to_string())]);
    }
    if let Some(d) = &job.confine {
        render.extend([os("--confine"), os(d)]);
    }
    render.extend(job.render_options.iter().cloned());
    assert_eq!(run_bash(&[render_path.as_os_str()], &cwd, &record, "render.sbatch"), vec![render]);
    let mut merge = vec![os(&scripts.folder), os("merge"), os(&job.output)];
    merge.extend((1..=n).map(|i| os(format!("tile-{i}.exr"))));
    assert_eq!(run_bash(&[merge_path.as_os_str()], &cwd, &record, "merge.sbatch"), vec![merge]);
    let commands = scripts.submit_commands();
    let submitted = run_bash(&[OsStr::new("-c"), OsStr::new(&commands)], &cwd, &record, "the submit commands");
    let submit = vec![
        vec![os(&cwd), os("--parsable"), os(&render_path)],
        vec![os(&cwd), os("--dependency=afterany:42"), os(&merge_path)],
    ];
    assert_eq!(submitted, submit);
    // Nothing else was made: the working folder is empty, the jobs' folder holds the scripts.
    assert!(std::fs::read_dir(&cwd).unwrap().next().is_none(), "a file in the working folder");
    let mut made: Vec<_> = std::fs::read_dir(&scripts.folder).unwrap().map(|e| e.unwrap().file_name()).collect();
    made.sort();
    assert_eq!(made, [os("merge.sbatch"), os("render.sbatch")]);
});
