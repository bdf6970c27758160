#!/usr/bin/env python3
"""Fuzz the scene reader with mutants of every shipped scene (issue 13, item 9).

Each scene in inputs/ gets --mutants mutants, made with a fixed seed, one mutation each, the
kinds taken in turn (with an offset per scene, so every kind meets every scene over the suite):
  value      a parameter's text replaced by junk ("abc", "", "nan", "1e999", "0x10", "{0.5 0.7}",
             a byte that is not UTF-8, ...), by a scaled number, or by another model's word
  type       a parameter's type attribute changed (int, double, string, bool, Array(...), float, "")
  name       a parameter's or list's name misspelt, emptied or changed in case
  duplicate  a parameter given twice (same or another value)
  nesting    a parameter wrapped in an extra list or moved into another list, a chain of 33 or
             10000 nested lists, or a list's opening tag removed
  truncation the file cut at a random byte
  bytes      one to three bytes replaced by XML metacharacters, NUL, 0xff or random bytes
  removal    a parameter line deleted (its default then applies, or a cross-check fails)
Every mutant is checked with `granflow --check`, which must exit 0 or 2. A mutant that passes
is run with Time->Max steps = 5 (Output->Directory moved to this test's directory), which must
exit 0, 2, 3 or 5. Both must end by an exit, not a signal or a hang; an exit 2 must name a
parameter ('granflow->...'), the list holding an element without a name, or the file's line
(malformed XML); a run's outputs (profiles.csv,
summary.json, fields.h5, checkpoint.h5) must hold no NaN or infinity, and summary.json must be
there and parse.

  fuzz_scenes.py --exe build/apps/granflow --inputs inputs --out DIR [--mutants 8] [--seed 13]
"""
import argparse
import concurrent.futures
import glob
import json
import math
import os
import random
import re
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mutate  # noqa: E402  (shares the line-based scene editing with the CLI tests)

KINDS = ["value", "type", "name", "duplicate", "nesting", "truncation", "bytes", "removal",
         "value"]
JUNK = [b"abc", b"", b" ", b"nan", b"inf", b"-inf", b"1e999", b"1e-400", b"0x10", b"50abc",
        b"4294967696", b"-2147483649", b"{0.5 0.7}", b"{nan, 1}", b"{}", b"{1, }", b"true",
        b"\xff", b"1,5", b"+-1", b"1e", b"50.9", b"8x", b"-0", b"\xc3\x28", b"&amp;"]
WORDS = [b"Minmod", b"Beam-Warming", b"Inflow", b"Outflow", b"Wall", b"Periodic", b"DAM",
         b"N-DAM", b"Coupled", b"CG", b"GMRES", b"MueLu", b"None", b"Nonlinear", b"Lagged",
         b"Dry", b"Uniform", b"Dam break", b"Implicit", b"No-slip", b"Free-slip", b"Bingham",
         b"{1D, 2D}", b"{2D, 1D, 2D}", b"{0.2, 0.7}", b"{0.7, 0.2}", b"false"]
TYPES = [b"int", b"double", b"string", b"bool", b"Array(double)", b"Array(string)",
         b"Array(int)", b"float", b"", b"Double", b"long long"]
NUMBER = re.compile(rb"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")
NAMES_TWO = re.compile(rb'(name=")([^"]*)(")')
# What an exit 2 must say: a parameter's path, or where in the file the XML is broken.
# (A few cross-checks in the components name a path without its 'granflow->' head, e.g. the
# N-DAM's 'Channel->Left boundary->Type': still the parameter.)
NAMED = re.compile(r"(parameter|list) '[^']+'|\bline [0-9]+\b")


def attr(line, name):
    m = re.search(rb"\s" + name + rb'="([^"]*)"', line)
    return m.group(1) if m else None


def mutate_scene(rng, lines, kind):
    """Apply one mutation of `kind` to `lines` (bytes lines); return a description."""
    params = mutate.parameter_lines(lines)
    path, i = rng.choice(params)
    if kind == "value":
        old = attr(lines[i], b"value") or b""
        r = rng.random()
        if r < 0.5:
            new = rng.choice(JUNK)
        elif r < 0.8 and NUMBER.match(old):
            # Scaled numbers stay within a few times the grid of the scene: integers are
            # halved, doubled, zeroed or negated (a 1000x grid would test memory, not input).
            is_int = attr(lines[i], b"type") == b"int"
            f = rng.choice([0, -1, 0.5, 2] if is_int else [0, -1, 0.5, 2, 1e-3, 1e3, 1e-12])
            v = float(old) * f
            new = str(int(v)).encode() if is_int else repr(v).encode()
        else:
            new = rng.choice(WORDS)
        lines[i] = mutate.set_attr(lines[i], b"value", new)
        return f"value of {path}: {old!r} -> {new!r}"
    if kind == "type":
        new = rng.choice(TYPES)
        lines[i] = mutate.set_attr(lines[i], b"type", new)
        return f"type of {path} -> {new!r}"
    if kind == "name":
        named = [k for k, l in enumerate(lines) if NAMES_TWO.search(l)]
        k = rng.choice(named)
        old = NAMES_TWO.search(lines[k]).group(2)
        ops = [lambda s: s[:-1], lambda s: s[1:] + s[:1], lambda s: s.upper(),
               lambda s: s + b" ", lambda s: b"", lambda s: s.replace(b" ", b"")]
        new = rng.choice(ops)(old)
        lines[k] = NAMES_TWO.sub(lambda m: m.group(1) + new + m.group(3), lines[k], count=1)
        return f"name {old!r} -> {new!r} (line {k + 1})"
    if kind == "duplicate":
        dup = lines[i]
        if rng.random() < 0.5:
            dup = mutate.set_attr(dup, b"value", rng.choice(JUNK + WORDS))
        lines.insert(i + 1 + rng.randrange(2), dup)
        return f"{path} given twice: {dup.strip()!r}"
    if kind == "nesting":
        r = rng.randrange(4)
        if r == 0:
            lines[i] = b'<ParameterList name="Extra">' + lines[i].rstrip(b"\n") + b"</ParameterList>\n"
            return f"{path} wrapped in a list 'Extra'"
        if r == 1:
            opens = [k for k, l in enumerate(lines) if mutate.LIST_OPEN.search(l)]
            line = lines.pop(i)
            k = rng.choice([k for k in opens if k != i])
            k = k if k < i else k - 1
            lines.insert(k + 1, line)
            return f"{path} moved into the list of line {k + 1}"
        if r == 2:
            depth = rng.choice([33, 10000])
            mutate.nest(lines, depth)
            return f"{depth} nested lists"
        opens = [k for k, l in enumerate(lines) if mutate.LIST_OPEN.search(l)]
        k = rng.choice(opens)
        del lines[k]
        return f"opening tag of line {k + 1} removed"
    if kind == "truncation":
        text = b"".join(lines)
        cut = rng.randrange(len(text))
        lines[:] = [text[:cut]]
        return f"truncated at byte {cut} of {len(text)}"
    if kind == "bytes":
        text = bytearray(b"".join(lines))
        done = []
        for _ in range(rng.randint(1, 3)):
            pos = rng.randrange(len(text))
            b = rng.choice([b"<", b">", b'"', b"/", b"&", b"\x00", b"\xff", bytes([rng.randrange(256)])])
            text[pos:pos + 1] = b
            done.append(f"{pos}:{b!r}")
        lines[:] = [bytes(text)]
        return "bytes replaced at " + ", ".join(done)
    if kind == "removal":
        del lines[i]
        return f"{path} removed"
    raise ValueError(kind)


def with_run_control(data, run_dir):
    """The mutant with Time->Max steps = 5 and Output->Directory = run_dir (None: no Time
    list to put the step limit in, so the mutant is not run)."""
    lines = data.splitlines(keepends=True)
    out, stack, time_seen, out_seen = [], [], False, False
    for line in lines:
        m = mutate.LIST_OPEN.search(line)
        if m:
            stack.append(m.group(1))
        p = mutate.PARAM.search(line)
        top = stack[1:] if len(stack) > 1 else []
        if p and top == [b"Time"] and p.group(1) == b"Max steps":
            line = re.sub(rb"<Parameter\s[^>]*/>", b"", line, count=1)
        if p and top == [b"Output"] and p.group(1) == b"Directory":
            line = re.sub(rb"<Parameter\s[^>]*/>", b"", line, count=1)
        out.append(line)
        if m and len(stack) == 2 and m.group(1) == b"Time" and not time_seen:
            out.append(b'<Parameter name="Max steps" type="int" value="5"/>\n')
            time_seen = True
        if m and len(stack) == 2 and m.group(1) == b"Output" and not out_seen:
            out.append(b'<Parameter name="Directory" type="string" value="' +
                       run_dir.encode() + b'"/>\n')
            out_seen = True
        if mutate.LIST_CLOSE.search(line) and stack:
            stack.pop()
    if not time_seen:
        return None
    if not out_seen:  # the run would write into the working directory's default 'output'
        return None
    return b"".join(out)


def nonfinite_in_h5(path):
    """Non-finite numbers in the floating-point datasets and attributes of an HDF5 file."""
    p = subprocess.run(["h5dump", path], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       timeout=60)
    if p.returncode != 0:
        return f"h5dump failed: {p.stderr.decode(errors='replace')[:200]}"
    floating = False
    for line in p.stdout.decode(errors="replace").splitlines():
        if "DATATYPE" in line:
            floating = "H5T_IEEE_F" in line
        elif floating and re.search(r"(?<![A-Za-z_])-?(nan|inf)(?![A-Za-z_])", line, re.I):
            return line.strip()[:200]
    return None


def nonfinite_in_json(value, where="summary"):
    if isinstance(value, float) and not math.isfinite(value):
        return where
    if isinstance(value, dict):
        for k, v in value.items():
            r = nonfinite_in_json(v, f"{where}.{k}")
            if r:
                return r
    if isinstance(value, list):
        for k, v in enumerate(value):
            r = nonfinite_in_json(v, f"{where}[{k}]")
            if r:
                return r
    return None


def check_outputs(run_dir):
    """Problems with a finished run's outputs (empty list: none)."""
    problems = []
    summary = os.path.join(run_dir, "summary.json")
    if not os.path.isfile(summary) or os.path.getsize(summary) == 0:
        return ["summary.json missing or empty"]
    try:
        with open(summary, "rb") as f:
            s = json.loads(f.read().decode("utf-8"))
    except (ValueError, UnicodeDecodeError) as e:
        return [f"summary.json does not parse: {e}"]
    bad = nonfinite_in_json(s)
    if bad:
        problems.append(f"non-finite number in {bad}")
    # nlohmann::json writes a NaN as null: the numbers of the run record must be numbers
    mb = s.get("mass_balance", {})
    for k in ("initial", "final", "defect"):
        if not isinstance(mb.get(k), (int, float)):
            problems.append(f"summary.json mass_balance.{k} = {mb.get(k)!r}")
    if not isinstance(s.get("final_time"), (int, float)):
        problems.append(f"summary.json final_time = {s.get('final_time')!r}")
    prof = os.path.join(run_dir, "profiles.csv")
    if os.path.isfile(prof):
        with open(prof, encoding="utf-8", errors="replace") as f:
            for n, line in enumerate(f, 1):
                for field in line.strip().split(","):
                    try:
                        v = float(field)
                    except ValueError:
                        continue
                    if not math.isfinite(v):
                        problems.append(f"profiles.csv line {n}: {line.strip()[:120]}")
                        break
                if problems:
                    break
    for h5 in ("fields.h5", "checkpoint.h5"):
        path = os.path.join(run_dir, h5)
        if os.path.isfile(path):
            bad = nonfinite_in_h5(path)
            if bad:
                problems.append(f"{h5}: {bad}")
    return problems


def granflow(exe, args, timeout):
    try:
        return mutate.run(exe, args, timeout)  # retries a start that MPI_Init aborted
    except subprocess.TimeoutExpired:
        return None, f"no exit within {timeout} s"


def judge(exe, mutant_file, run_dir, timeout):
    """(problems, outcome) of one mutant."""
    problems = []
    code, out = granflow(exe, ["--check", mutant_file], timeout)
    outcome = f"check {code}"
    if code is None or code < 0 or code not in (0, 2):
        return [f"--check ended with {'signal ' + str(-code) if code and code < 0 else code}: "
                f"{out[-400:]}"], outcome
    if code == 2:
        if not NAMED.search(out):
            problems.append(f"--check exit 2 names no parameter or line: {out[-400:]}")
        return problems, outcome
    with open(mutant_file, "rb") as f:
        data = with_run_control(f.read(), run_dir)
    if data is None:
        return problems, outcome + ", not run (no Time or Output list)"
    run_file = mutant_file[:-4] + "_run.xml"
    with open(run_file, "wb") as f:
        f.write(data)
    shutil.rmtree(run_dir, ignore_errors=True)
    code, out = granflow(exe, [run_file], timeout)
    outcome += f", run {code}"
    if code is None or code < 0 or code not in (0, 2, 3, 5):
        return [f"run ended with {'signal ' + str(-code) if code and code < 0 else code}: "
                f"{out[-400:]}"], outcome
    if code == 2:
        if not NAMED.search(out):
            problems.append(f"run exit 2 names no parameter or line: {out[-400:]}")
        return problems, outcome
    problems += check_outputs(run_dir)
    return problems, outcome


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--exe", required=True)
    ap.add_argument("--inputs", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--mutants", type=int, default=8, help="mutants per scene")
    ap.add_argument("--seed", type=int, default=13)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=120.0, help="seconds per granflow call")
    a = ap.parse_args()

    shutil.rmtree(a.out, ignore_errors=True)
    os.makedirs(a.out)
    out_dir = os.path.abspath(a.out)
    rng = random.Random(a.seed)
    cases = []  # (scene, kind, description, mutant file, run dir)
    for si, scene in enumerate(sorted(glob.glob(os.path.join(a.inputs, "*.xml")))):
        with open(scene, "rb") as f:
            original = f.read()
        name = os.path.splitext(os.path.basename(scene))[0]
        for m in range(a.mutants):
            kind = KINDS[(si + m) % len(KINDS)]
            for _ in range(20):  # a mutation that changes nothing (Implicit -> Implicit) is redrawn
                lines = original.splitlines(keepends=True)
                what = mutate_scene(rng, lines, kind)
                if b"".join(lines) != original:
                    break
            mutant = os.path.join(out_dir, f"{name}_{m}.xml")
            with open(mutant, "wb") as f:
                f.write(b"".join(lines))
            cases.append((name, kind, what, mutant, os.path.join(out_dir, f"{name}_{m}_run")))

    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(lambda c: judge(a.exe, c[3], c[4], a.timeout), cases))

    failures = 0
    tally = {}
    for (name, kind, what, mutant, _), (problems, outcome) in zip(cases, results):
        tally[outcome] = tally.get(outcome, 0) + 1
        status = "FAIL" if problems else "ok"
        print(f"{status:4} {os.path.basename(mutant):34} {kind:10} {outcome:18} {what[:90]}")
        for p in problems:
            print(f"     {p}")
        failures += bool(problems)
    print(f"\n{len(cases)} mutants of {len(cases) // a.mutants} scenes (seed {a.seed}): " +
          ", ".join(f"{k}: {v}" for k, v in sorted(tally.items())))
    if failures:
        print(f"{failures} mutants failed; their files are in {out_dir}")
        sys.exit(1)


if __name__ == "__main__":
    main()
