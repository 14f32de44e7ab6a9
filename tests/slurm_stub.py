#!/usr/bin/env python3
"""A stand-in for Slurm's sbatch in strahl's tests (tests/farm.rs), where no Slurm runs.

Usage: slurm_stub.py [OPTIONS] SCRIPT [ARGS...], as sbatch (tests/farm.rs puts it on PATH as
`sbatch`). It reads the options of the command line and of the script's #SBATCH lines as
sbatch (Slurm 22.05) does:

- a script must start with `#!` and hold no NUL byte and no `\\r\\n` pair (sbatch.c);
- the directives are the lines starting with `#SBATCH`, up to the first line that is not a
  comment; a line ends at a newline; it is split into words as `get_argument` in
  src/sbatch/opt.c splits it: white space separates words outside '...' and "...", a
  backslash takes the next character as it is, an unquoted `#` ends the line, a word that
  copies nothing ends the line too;
- the words are options (getopt_long: `--name=value`, `--name value`, `-xvalue`, `-x value`);
  a word that is no option is an error ("Invalid directive"), as is an unknown option (only
  the options strahl writes are known: stricter than sbatch);
- the command line's options override the script's.

It prints the job id (`--parsable`: the id alone) and records each submission as a JSON line
in $SBATCH_STUB_DIR/submissions.jsonl: its arguments, the script, the final options and the
job id (SBATCH_STUB_JOB_ID=N: N, as a requeued job keeps its id). With SBATCH_STUB_RUN=1 it then runs the script at once, once per array task, with
$SBATCH_STUB_SHELL (default bash), in the submitting directory, with the variables Slurm sets
(SLURM_JOB_ID, SLURM_ARRAY_JOB_ID, SLURM_ARRAY_TASK_ID, SLURM_JOB_NAME, ...), its stdout and
stderr in the --output file named as slurmstepd names it (src/slurmd/common/fname.c: %A %a %j
%J %x %u %N %n %s %t replaced, %% a %, and a backslash anywhere turns the replacing off and
is removed), appended with --open-mode=append, truncated otherwise; each run is recorded as a
JSON line too (task, log file, exit status).
"""

import getpass
import json
import os
import re
import socket
import subprocess
import sys

SPACE = b" \t\n\v\f\r"
VALUE_OPTIONS = {
    "output": "o", "error": "e", "open-mode": None, "partition": "p", "time": "t",
    "cpus-per-task": "c", "array": "a", "job-name": "J", "dependency": "d", "chdir": "D",
}
FLAG_OPTIONS = {"requeue": None, "no-requeue": None, "parsable": None}
SHORT = {v: k for k, v in VALUE_OPTIONS.items() if v}


def fail(message):
    sys.stderr.write(f"sbatch: error: {message}\n")
    sys.exit(1)


def directive_words(rest, lineno):
    """The words of one #SBATCH line after the magic word (get_argument, repeated)."""
    words, i, n = [], 0, len(rest)
    while True:
        while i < n and rest[i] in SPACE:
            i += 1
        if i >= n:
            return words
        if rest[i:i + 1] == b":":
            fail(f"line {lineno}: Unexpected `:`")
        arg, copied, quote, escape = bytearray(), False, None, False
        while i < n and (quote is not None or rest[i] not in SPACE) and rest[i] != 0x0A:
            c = rest[i]
            if escape:
                escape = False
            elif c == 0x5C:  # backslash
                i += 1
                if i < n and rest[i] == 0x20:
                    arg.append(0x20)
                    copied = True
                    i += 1
                else:
                    escape = True
                continue
            elif quote is not None:
                if c == quote:
                    quote = None
                    i += 1
                    continue
            elif c in (0x22, 0x27):
                quote = c
                i += 1
                continue
            elif c == 0x23:  # an unquoted '#': the rest is a comment
                break
            arg.append(c)
            copied = True
            i += 1
        if quote is not None:
            fail(f"line {lineno}: Unmatched `{chr(quote)}`")
        if not copied:
            return words
        words.append(bytes(arg))


def directives(body):
    """Every word of the script's #SBATCH lines, in order."""
    words = []
    for lineno, line in enumerate(body.split(b"\n"), 1):
        if line.startswith(b"#SBATCH"):
            words += directive_words(line[len(b"#SBATCH"):], lineno)
        elif line.startswith(b"#SLURM"):
            words += directive_words(line[len(b"#SLURM"):], lineno)
        else:
            first = line.lstrip(SPACE)[:1]
            if first and first != b"#":
                break
    return words


def parse_options(words, options, where, stop_at_word):
    """getopt_long over `words` into `options`; returns the index of the first non-option."""
    i = 0
    while i < len(words):
        w = words[i]
        if w == "--":
            return i + 1
        if w.startswith("--"):
            name, eq, value = w[2:].partition("=")
            if name in FLAG_OPTIONS:
                if eq:
                    fail(f"{where}: option '--{name}' doesn't allow an argument")
                options[name] = True
            elif name in VALUE_OPTIONS:
                if not eq:
                    i += 1
                    if i >= len(words):
                        fail(f"{where}: option '--{name}' requires an argument")
                    value = words[i]
                options[name] = value
            else:
                fail(f"{where}: unrecognized option '{w}'")
        elif w.startswith("-") and len(w) > 1:
            name = SHORT.get(w[1])
            if name is None:
                fail(f"{where}: invalid option -- '{w[1]}'")
            value = w[2:]
            if not value:
                i += 1
                if i >= len(words):
                    fail(f"{where}: option requires an argument -- '{w[1]}'")
                value = words[i]
            options[name] = value
        elif stop_at_word:
            return i
        else:
            fail(f"Invalid directive found in batch script: {w}")
        i += 1
    return i


def array_tasks(spec):
    """The task ids of an --array specification: 1-8, 1,3,5, 2-10:2, with an optional %N."""
    tasks = []
    for part in spec.split("%")[0].split(","):
        m = re.fullmatch(r"(\d+)(?:-(\d+)(?::(\d+))?)?", part)
        if not m:
            fail(f"Invalid job array specification: {spec}")
        first = int(m.group(1))
        last = int(m.group(2) or first)
        step = int(m.group(3) or 1)
        tasks += range(first, last + 1, step)
    return tasks


def log_name(pattern, cwd, job):
    """slurmstepd's name for the --output pattern (fname_create, batch job)."""
    if "\\" in pattern:
        # remove_path_slashes: `\\` is a `\`, any other backslash is dropped; nothing replaced.
        name = re.sub(r"\\(.)", r"\1", pattern).replace("\\", "")
    else:
        def replace(m):
            if m.group(0) == "%%":
                return "%"
            width, key = min(int(m.group(1) or 0), 10), m.group(2)
            value = {
                "A": job["array_job_id"], "a": job["task"], "j": job["job_id"], "J": job["job_id"],
                "x": job["name"], "u": getpass.getuser(), "N": socket.gethostname(), "n": 0,
                "s": "batch", "t": 0,
            }[key]
            return f"{value:0{width}d}" if isinstance(value, int) else str(value)
        name = re.sub(r"%%|%(\d*)([AajJxuNnst])", replace, pattern)
    return name if name.startswith("/") else os.path.join(cwd, name)


def main():
    argv = [os.fsdecode(a) if isinstance(a, bytes) else a for a in sys.argv[1:]]
    options = {}
    first = parse_options(argv, options, "sbatch", stop_at_word=True)
    if first >= len(argv):
        fail("no batch script given (the stub does not read stdin)")
    script, script_args = argv[first], argv[first + 1:]
    with open(script, "rb") as f:
        body = f.read()
    if not body.startswith(b"#!"):
        fail("This does not look like a batch script.  The first line must start with #!")
    if b"\0" in body:
        fail("The batch script contains a NULL character '\\0'.")
    if b"\r\n" in body:
        fail("Batch script contains DOS line breaks (\\r\\n)")
    words = [w.decode("utf-8", "surrogateescape") for w in directives(body)]
    final = {}
    parse_options(words, final, "script", stop_at_word=False)
    parse_options(argv[:first], final, "sbatch", stop_at_word=True)

    state = os.environ["SBATCH_STUB_DIR"]
    counter = os.path.join(state, "next_id")
    job_id = int(open(counter).read()) if os.path.exists(counter) else 100
    tasks = array_tasks(final["array"]) if "array" in final else None
    with open(counter, "w") as f:
        f.write(str(job_id + 1 + len(tasks or [])))
    # A requeued job keeps its id: SBATCH_STUB_JOB_ID runs a job again under the id it names.
    job_id = int(os.environ.get("SBATCH_STUB_JOB_ID", job_id))
    record = {"argv": argv, "script": script, "script_args": script_args, "directives": words,
              "options": final, "job_id": job_id}
    with open(os.path.join(state, "submissions.jsonl"), "a") as f:
        f.write(json.dumps(record) + "\n")
    print(job_id if "parsable" in options else f"Submitted batch job {job_id}", flush=True)

    if os.environ.get("SBATCH_STUB_RUN") != "1":
        return
    cwd = final.get("chdir", os.getcwd())
    name = final.get("job-name", os.path.basename(script))
    default = "slurm-%A_%a.out" if tasks is not None else "slurm-%j.out"
    shell = os.environ.get("SBATCH_STUB_SHELL", "bash")
    for k, task in enumerate(tasks if tasks is not None else [None]):
        job = {"job_id": job_id + k, "array_job_id": job_id, "task": task if task is not None else 4294967294,
               "name": name}
        env = dict(os.environ, SLURM_JOB_ID=str(job["job_id"]), SLURM_JOB_NAME=name,
                   SLURM_SUBMIT_DIR=os.getcwd())
        for key in ("SBATCH_STUB_RUN", "SBATCH_STUB_DIR", "SBATCH_STUB_SHELL", "SBATCH_STUB_JOB_ID"):
            env.pop(key, None)
        if task is not None:
            env.update(SLURM_ARRAY_JOB_ID=str(job_id), SLURM_ARRAY_TASK_ID=str(task),
                       SLURM_ARRAY_TASK_COUNT=str(len(tasks)), SLURM_ARRAY_TASK_MIN=str(min(tasks)),
                       SLURM_ARRAY_TASK_MAX=str(max(tasks)))
        if "cpus-per-task" in final:
            env["SLURM_CPUS_PER_TASK"] = final["cpus-per-task"]
        log = log_name(final.get("output", default), cwd, job)
        mode = "ab" if final.get("open-mode") == "append" else "wb"
        with open(log, mode) as out:
            status = subprocess.run([shell, script, *script_args], cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                                    stdout=out, stderr=out).returncode
        with open(os.path.join(state, "submissions.jsonl"), "a") as f:
            f.write(json.dumps({"ran": job_id, "task": task, "log": log, "status": status}) + "\n")


if __name__ == "__main__":
    main()
