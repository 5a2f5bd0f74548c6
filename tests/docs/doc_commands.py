#!/usr/bin/env python3
"""Every shell command of README.md and docs/*.md runs as written (ctest: docs.commands).

The docs' convention (docs/ARCHITECTURE.md, tests/):
  ```sh       commands to run, one per line (a trailing backslash continues one); comments are the shell's.
  ```console  `$ command` lines, each followed by what it prints: the command runs, and each line quoted after it
              (its figures) must be a line it prints, stdout or stderr, times aside (a number of s or ms is
              whatever it takes). A quoted line `...` stands for lines left out. A command that quotes an
              `error: ` line must fail as the docs say errors do: exit code 2 (bad input) or 3 (measured wrong).
  ```text     output, messages or command lines that are not meant to run (illustrations): never run.
Every block says which it is (or its language: yaml, python, ...): an untagged block fails the test.
A command on the line after `# untested: WHY` is not run (WHY says why: it takes minutes, it needs your own files).

The commands run from a copy of the checkout's files (a fresh clone's layout) whose build/bin and build/python are the
build tree's, in the order of the README, then docs/ by name, so the README's learning of build/biped.approx.yaml
serves the pages after it. A command that names ../shared is skipped when the checkout has no ../shared. A command
is given 120 s. Exit code: 0 when every command ran as written, 1 otherwise (each failure said on stderr).

Usage: doc_commands.py SOURCE_DIR BUILD_DIR SCRATCH_DIR [DOC...]
"""

import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import time

# The README's two commands set up and build what this test runs: they are what ctest itself comes from.
NOT_RUN = {"./quickstart.sh", "./test.sh"}
TIMEOUT = 120
CMU_CLIP = pathlib.Path("/usr/share/assimp/models/BVH/01_01.bvh")
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```[ \t]*$", re.S | re.M)
# A time: whatever a run takes ("0.03 s learning", "0.1025 ms per frame", "12.3 ms").
TIME = re.compile(r"[0-9][0-9.e+-]*( ?(?:s|ms|seconds)\b)")


def logical_lines(body):
    """The lines of a block with trailing-backslash continuations joined."""
    lines, current = [], ""
    for line in body.splitlines():
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        lines.append(current + line)
        current = ""
    if current:
        lines.append(current)
    return lines


def commands_of(doc, text):
    """(line number, kind, command, expected lines, untested reason) for each command of the doc."""
    found = []
    for match in FENCE.finditer(text):
        kind, body = match.group(1), match.group(2)
        line = text.count("\n", 0, match.start()) + 2
        if kind == "":
            found.append((line, "untagged", body.splitlines()[0] if body else "", [], None))
            continue
        if kind not in ("sh", "console"):
            continue
        untested = None
        lines = logical_lines(body)
        for i, entry in enumerate(lines):
            stripped = entry.strip()
            if stripped.startswith("# untested:"):
                untested = stripped[len("# untested:"):].strip()
                continue
            if kind == "sh":
                if not stripped or stripped.startswith("#"):
                    continue
                found.append((line, kind, entry, [], untested))
            elif entry.startswith("$ "):
                expected = []
                for after in lines[i + 1:]:
                    if after.startswith("$ ") or after.strip().startswith("# untested:"):
                        break
                    expected.append(after)
                found.append((line, kind, entry[2:], expected, untested))
            untested = None
    return found


def masked(line):
    return TIME.sub(r"<time>\1", line.rstrip())


def missing_lines(expected, printed):
    """The quoted lines a run did not print (times aside)."""
    lines = {masked(line) for line in printed.splitlines()}
    return [line for line in expected if line.strip() and line.strip() != "..." and masked(line) not in lines]


def make_tree(source, build, tree):
    """A copy of the checkout's files, with the build tree's programs and Python module."""
    if tree.exists():
        shutil.rmtree(tree)
    listed = subprocess.run(["git", "-C", str(source), "ls-files", "-z"], capture_output=True)
    if listed.returncode == 0:
        names = listed.stdout.decode().split("\0")
    else:  # not a git checkout (a release's sources): every file but the build trees
        names = [str(f.relative_to(source)) for f in source.rglob("*")
                 if f.is_file() and not f.relative_to(source).parts[0].startswith("build")]
    for name in names:
        if not name or not (source / name).exists():
            continue
        target = tree / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source / name, target, follow_symlinks=False)
    (tree / "build").mkdir()
    for part in ("bin", "python", "test-plugins"):
        if (build / part).exists():
            (tree / "build" / part).symlink_to(build / part)
    shared = source.parent / "shared"
    if shared.exists():
        (tree.parent / "shared").unlink(missing_ok=True)
        (tree.parent / "shared").symlink_to(shared.resolve())


def run_command(command, tree, env):
    """The command's run through bash (a pipe fails when any of its programs does); None when it outlasts TIMEOUT,
    its whole process group then stopped."""
    process = subprocess.Popen(["bash", "-c", "set -o pipefail; " + command], cwd=tree, env=env, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        out, err = process.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        return None
    return subprocess.CompletedProcess(command, process.returncode, out, err)


def run_doc(doc, tree, env, have_shared):
    failures, ran, skipped = [], 0, 0
    for line, kind, command, expected, untested in commands_of(doc.name, doc.read_text()):
        where = f"{doc.relative_to(tree)}:{line}"
        if kind == "untagged":
            failures.append(f"{where}: a block without a tag: mark it ```sh or ```console (run and checked), "
                            f"```text (not run) or its language")
            continue
        if untested is not None or command.split("#")[0].strip() in NOT_RUN:
            skipped += 1
            continue
        if "../shared" in command and not have_shared:
            print(f"{where}: skipped (no ../shared): {command}")
            skipped += 1
            continue
        start = time.monotonic()
        done = run_command(command, tree, env)
        if done is None:
            failures.append(f"{where}: still running after {TIMEOUT} s (mark it # untested: WHY): {command}")
            continue
        ran += 1
        seconds = time.monotonic() - start
        fails = any(line.startswith("error: ") for line in expected)
        if (done.returncode not in (2, 3)) if fails else done.returncode != 0:
            failures.append(f"{where}: exit code {done.returncode}{' (2 or 3 for its error)' if fails else ''}: "
                            f"{command}\n{done.stderr[-2000:]}")
            continue
        missing = missing_lines(expected, done.stdout + done.stderr)
        if missing:
            failures.append(f"{where}: {command}\n  quoted but not printed:\n    " + "\n    ".join(missing) +
                            "\n  printed:\n    " + "\n    ".join((done.stdout + done.stderr).splitlines()[:60]))
        print(f"{where}: {seconds:.1f} s: {command[:100]}")
    return failures, ran, skipped


def main():
    source, build, scratch = (pathlib.Path(arg).resolve() for arg in sys.argv[1:4])
    if not CMU_CLIP.exists():
        # The docs' commands invert it nearly all: without it they say nothing about the docs.
        print(f"[skipped] {CMU_CLIP} is not installed (Debian package assimp-testmodels)")
        return 0
    tree = scratch / "tree"
    make_tree(source, build, tree)
    docs = [tree / "README.md"] + sorted((tree / "docs").glob("*.md"))
    if len(sys.argv) > 4:
        docs = [tree / name for name in sys.argv[4:]]
    env = dict(os.environ, PATH=f"{tree / 'build' / 'bin'}:{os.environ.get('PATH', '')}",
               PYTHONPATH=str(tree / "build" / "python"), PYTHONDONTWRITEBYTECODE="1",
               MPLCONFIGDIR=str(scratch / "matplotlib"))
    failures, ran, skipped = [], 0, 0
    for doc in docs:
        f, r, s = run_doc(doc, tree, env, (source.parent / "shared").exists())
        failures += f
        ran += r
        skipped += s
    for failure in failures:
        print(f"FAILED {failure}", file=sys.stderr)
    print(f"{ran} commands run, {skipped} not run (untested or no ../shared), {len(failures)} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
