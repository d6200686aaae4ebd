"""The ``dmprs`` command line: learn, record demonstrations, plot and resume runs."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from dmprs import demo, experiments
from dmprs._extras import require
from dmprs.errors import DmprsError, InvalidInputError
from dmprs.experiments import learner_help
from dmprs.io.importer import build_database, load_demos
from dmprs.loop import LearningResult, learn
from dmprs.plots import plot_run
from dmprs.reproduce import PartTime, reproduce, skipped
from dmprs.reproduce.check import check_summary
from dmprs.reproduce.tables import docs_targets, update_docs
from dmprs.runlog import RunLog


def _progress(console: Any) -> Any:
    def show(record: Any) -> None:
        eps = "-" if record.eps is None else ", ".join(f"{e:+.4g}" for e in record.eps)
        q = ", ".join(f"{v:.4g}" for v in record.query)
        mark = "[green]success[/green]" if record.success else record.status
        console.print(f"trial {record.index + 1:>3}  query [{q}]  eps [{eps}]  {mark}")
    return show


def _console() -> Any:
    from rich.console import Console

    return Console(highlight=False)


def _report(console: Any, result: Any) -> None:
    if result.cut_note:
        console.print(f"[yellow]note:[/yellow] {result.cut_note}")
    verdict = "[green]converged[/green]" if result.converged else "[red]not converged[/red]"
    q = None if result.learned_query is None else [round(float(v), 6) for v in result.learned_query]
    console.print(f"{verdict} after {result.n_trials} trial(s): {result.stop_reason}; learned query {q}")
    if result.log_dir is not None:
        console.print(f"log: {result.log_dir}")


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="dmprs")
def main() -> None:
    """Learn robot skills from a few demonstrations (Nemec, Vuga, Ude 2013)."""


@main.command("learn")
@click.argument("task")
@click.option("--learner", default=None,
              help=f"{learner_help()} (default: auto; each task offers some)")
@click.option("--desired", type=float, default=None, help="desired query (task units; arm-juggling: the apex in m)")
@click.option("--max-trials", type=click.IntRange(min=1, max=10**6), default=20, show_default=True)
@click.option("--tol", type=float, default=None, help="success when |eps| < tol (default: the task's criterion)")
@click.option("--log-dir", type=click.Path(path_type=Path), default=None, help="run directory for the trial log")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--noise", type=click.FloatRange(min=0.0, max=1e6), default=None,
              help="measurement noise (analytic task)")
@click.option("--volume", type=float, default=None, help="bottle volume in litres (pouring, arm-pouring)")
@click.option("--demos", default=None, help="demonstration set (matchbox: default | both_flipped_back)")
@click.option("--target", type=float, nargs=2, default=None, help="basket position X Y in m (arm-throwing)")
@click.option("--generalizer", default=None, help="linear | lwr-gp | lwr-gp-affine (arm-throwing)")
@click.option("--robot", type=click.Choice(["sim", "ros2"]), default=None,
              help="arm-pouring, arm-throwing: the scene in this process (sim, default) or a ROS 2 robot "
              "(ros2, e.g. `dmprs robot serve TASK`)")
@click.option("--domain-id", type=click.IntRange(min=0, max=232), default=None, envvar="ROS_DOMAIN_ID",
              show_envvar=True, help="the ROS 2 robot's domain (with --robot ros2; default 0)")
def learn_cmd(task: str, learner: str | None, desired: float | None, max_trials: int,
              tol: float | None, log_dir: Path | None, seed: int, noise: float | None,
              volume: float | None, demos: str | None, target: tuple[float, float] | None,
              generalizer: str | None, robot: str | None, domain_id: int | None) -> None:
    """Learn TASK (analytic, matchbox, pouring, arm-pouring, arm-throwing, arm-juggling) from its
    demonstrations, one trial at a time.
    """
    options: dict[str, Any] = {k: v for k, v in {
        "desired": desired, "noise": noise, "bottle_volume": volume, "demos": demos,
        "target": target, "generalizer": generalizer, "robot": robot, "domain_id": domain_id}.items()
        if v is not None}
    console = _console()
    try:
        result = experiments.run(task, learner=learner, max_trials=max_trials, tol=tol,
                                 log_dir=log_dir, seed=seed, on_trial=_progress(console), **options)
    except (DmprsError, TypeError) as exc:
        raise click.ClickException(str(exc)) from None
    _report(console, result)
    sys.exit(0 if result.converged else 1)


_MISSING = object()


def _field(meta: dict[str, Any], name: str, kind: Any, where: Path, default: Any = _MISSING) -> Any:
    """``meta[name]`` if it has the type ``kind`` (booleans are not numbers here), else an error
    naming the file and the field; ``default`` when it is absent (or null, for optional ones).
    """
    value = meta.get(name, _MISSING)
    if value is _MISSING or (value is None and default is not _MISSING):
        if default is _MISSING:
            raise DmprsError(f"{where}: the field {name!r} is missing")
        return default
    if isinstance(value, bool) or not isinstance(value, kind):
        want = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
        raise DmprsError(f"{where}: the field {name!r} is {value!r:.60}, expected {want}")
    return value


@main.command("resume")
@click.argument("run", type=click.Path(path_type=Path))
@click.option("--max-trials", type=click.IntRange(min=1), default=None, help="raise the trial cap of the run")
def resume_cmd(run: Path, max_trials: int | None) -> None:
    """Continue the run logged in RUN where it stopped."""
    console = _console()
    try:
        result = _resume(run, max_trials, console)
    except DmprsError as exc:
        raise click.ClickException(str(exc)) from None
    _report(console, result)
    sys.exit(0 if result.converged else 1)


def _resume(run: Path, max_trials: int | None, console: Any) -> LearningResult:
    """The run logged in ``run``, continued; every fault of the log is a DmprsError naming it."""
    meta = RunLog(run).meta()
    where = run / "run.json"
    if "experiment" not in meta:
        raise DmprsError(f"{where} was not written by 'dmprs learn': resume it from Python")
    experiment = _field(meta, "experiment", str, where)
    if experiment not in experiments.EXPERIMENTS:
        raise DmprsError(f"{where}: experiment {experiment!r} is unknown; "
                         f"known: {', '.join(sorted(experiments.EXPERIMENTS))}")
    setup_options = _field(meta, "setup_options", dict, where, {})
    learner_options = _field(meta, "learner_options", dict, where, {})
    learner_name = _field(meta, "learner_name", str, where)
    logged_cap = _field(meta, "max_trials", int, where)
    tol = _field(meta, "tol", (int, float), where, None)
    seed = _field(meta, "seed", int, where, 0)
    # A logged option that does not fit is the log's fault: say which field of which file.
    try:
        setup = experiments.make(experiment, **setup_options)
    except (TypeError, ValueError) as exc:
        raise DmprsError(f"{where}: setup_options {setup_options!r:.80} do not fit {experiment!r} ({exc})") from None
    try:
        learner = setup.make_learner(learner_name, **learner_options)
    except (TypeError, ValueError) as exc:
        raise DmprsError(f"{where}: learner_options do not fit {learner_name!r} ({exc})") from None
    try:
        return learn(setup.task, setup.generalizer, setup.desired_query, learner,
                     max_trials=logged_cap if max_trials is None else max_trials, tol=tol,
                     log_dir=run, resume=True, seed=seed, on_trial=_progress(console))
    except InvalidInputError as exc:
        raise DmprsError(f"{where}: {exc}") from None


class _RecordByDefault(click.Group):
    """``dmprs demos TASK`` still records TASK's demonstrations: a first word that is not a
    subcommand is taken as ``record``'s argument.
    """

    def resolve_command(self, ctx: click.Context, args: list[str]) -> Any:
        if args and args[0] not in self.commands and not args[0].startswith("-"):
            args = ["record", *args]
        return super().resolve_command(ctx, args)


@main.group("demos", cls=_RecordByDefault)
def demos_group() -> None:
    """Demonstration databases: record a task's scripted ones, or import your own."""


@demos_group.command("record")
@click.argument("task")
@click.option("--out", type=click.Path(path_type=Path), required=True, help="database directory to write")
@click.option("--demos", default=None, help="demonstration set (matchbox: default | both_flipped_back)")
def demos_cmd(task: str, out: Path, demos: str | None) -> None:
    """Record TASK's scripted demonstrations into a database directory."""
    try:
        setup = experiments.make(task, **({"demos": demos} if demos else {}))
        setup.database.save(out)
    except DmprsError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"{len(setup.database)} demonstrations of {task} written to {out}")


def _ranges(text: str | None) -> list[tuple[float, float]] | None:
    if text is None:
        return None
    try:
        return [(float(a), float(b)) for a, b in (part.split(":") for part in text.split(","))]
    except ValueError:
        raise click.ClickException(f"--ranges {text!r}: expected START:STOP[,START:STOP...] in seconds") from None


def _names(text: str | None) -> list[str] | None:
    return None if text is None else [n.strip() for n in text.split(",") if n.strip()]


class _ImportProgress:
    """A rich progress bar on stderr while ``dmprs demos import`` reads (fed by load_demos'
    progress callback, :attr:`callback`) and while it writes the database (between :meth:`start`
    and :meth:`stop`); nothing when not shown.
    """

    def __init__(self, show: bool) -> None:
        self.bar: Any = None
        self.tasks: dict[Path, Any] = {}
        self.stages: list[Any] = []
        if show:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

            self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                TimeRemainingColumn(), console=Console(stderr=True))

    def start(self) -> None:
        if self.bar is not None:
            self.bar.start()

    def stop(self) -> None:
        if self.bar is not None:
            self.bar.stop()

    @property
    def callback(self) -> Any:
        return None if self.bar is None else self._update

    def _update(self, source: Path, done: int, total: int) -> None:
        if source not in self.tasks:
            self.tasks[source] = self.bar.add_task(f"reading {source.name}", total=total)
        self.bar.update(self.tasks[source], completed=done, total=total)

    def stage(self, text: str) -> None:
        """A step of unknown length (building and writing the database), until :meth:`done`."""
        if self.bar is not None:
            self.stages.append(self.bar.add_task(text, total=None))

    def done(self) -> None:
        for task in self.stages:
            self.bar.update(task, total=1, completed=1)


@demos_group.command("import")
@click.argument("sources", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--out", type=click.Path(path_type=Path), required=True, help="database directory to write")
@click.option("--queries", type=click.Path(path_type=Path), default=None,
              help="CSV or JSON table: a 'demo' column naming each demonstration, one column per query dimension")
@click.option("--query-field", "query_fields", default=None,
              help="take the query from these label fields instead (comma-separated; LeRobot episode fields, npz scalars)")
@click.option("--units", default=None, help="units of the query dimensions (comma-separated)")
@click.option("--format", "fmt", type=click.Choice(["auto", "rosbag", "lerobot", "csv", "npz"]), default="auto",
              show_default=True)
@click.option("--topic", default="/joint_states", show_default=True, help="sensor_msgs/JointState topic (bags)")
@click.option("--joints", default=None, help="joints to keep, in order (comma-separated; bags)")
@click.option("--pose-topic", default=None, help="read poses from this geometry_msgs/PoseStamped topic instead (bags)")
@click.option("--tf", "tf_frames", default=None, help="read poses of CHILD in FRAME from TF instead, as FRAME:CHILD (bags)")
@click.option("--column", default="observation.state", show_default=True, help="frame column (LeRobot)")
@click.option("--dims", default=None, help="components of the column to keep, by name (LeRobot)")
@click.option("--time-column", default="t", show_default=True, help="time column (CSV)")
@click.option("--ranges", default=None, help="cut each recording at START:STOP,... (s of its own clock)")
@click.option("--rest-speed", type=float, default=None, help="cut each recording where its speed falls below this")
@click.option("--rest-angular-speed", type=float, default=0.05, show_default=True,
              help="rad/s; with poses, a rest also needs the angular speed below this")
@click.option("--rate", type=float, default=None, help="resample every demonstration at this rate (Hz)")
@click.option("--progress/--no-progress", "show_progress", default=None,
              help="show a progress bar on stderr (default: when stderr is a terminal)")
def demos_import_cmd(sources: tuple[Path, ...], out: Path, queries: Path | None, query_fields: str | None,
                     units: str | None, fmt: str, topic: str, joints: str | None, pose_topic: str | None,
                     tf_frames: str | None, column: str, dims: str | None, time_column: str,
                     ranges: str | None, rest_speed: float | None, rest_angular_speed: float,
                     rate: float | None, show_progress: bool | None) -> None:
    """Build a database from SOURCES: ROS bags, LeRobot datasets, CSV or npz files."""
    tf = None
    if tf_frames is not None:
        frame, _, child = tf_frames.partition(":")
        if not frame or not child:
            raise click.ClickException(f"--tf {tf_frames!r}: expected FRAME:CHILD")
        tf = (frame, child)
    if show_progress is None:
        show_progress = sys.stderr.isatty()
    try:
        progress = _ImportProgress(show_progress)
        progress.start()
        try:
            demos = load_demos(sources, format=fmt, topic=topic, joints=_names(joints), column=column,
                               dims=_names(dims), time_column=time_column, ranges=_ranges(ranges),
                               rest_speed=rest_speed, rest_angular_speed=rest_angular_speed, rate=rate,
                               pose_topic=pose_topic, tf=tf, progress=progress.callback)
            progress.stage(f"writing {len(demos)} demonstrations to {out}")
            db = build_database(demos, queries=queries, query_fields=_names(query_fields),
                                query_units=_names(units))
            db.save(out)
            progress.done()
        finally:
            progress.stop()
    except DmprsError as exc:
        raise click.ClickException(" ".join(str(exc).split("\n"))) from None  # one line
    labels = [d.label or "" for d in db]
    shown = ", ".join(labels[:8]) + (f", ... {labels[-1]}" if len(labels) > 8 else "")
    click.echo(f"{len(db)} demonstrations ({shown}) written to {out}")


@main.command("plot")
@click.argument("run", type=click.Path(path_type=Path))
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="image file (.png, .pdf, .svg, ...) or an existing folder to write learning.png into "
                   "(default RUN/learning.png)")
def plot_cmd(run: Path, out: Path | None) -> None:
    """Plot error and query per trial of RUN (like the paper's Figs. 4 and 9)."""
    try:
        path = plot_run(run, out)
    except DmprsError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"figure written to {path}")


@main.group("robot")
def robot_group() -> None:
    """Simulated robots served over ROS 2."""


@robot_group.command("serve")
@click.argument("task", type=click.Choice(["arm-throwing", "arm-pouring"]))
@click.option("--domain-id", type=click.IntRange(min=0, max=232), default=0, show_default=True,
              envvar="ROS_DOMAIN_ID", show_envvar=True, help="the ROS 2 domain to serve on")
@click.option("--speed", type=click.FloatRange(min=0.01, max=1000.0), default=1.0, show_default=True,
              help="playback speed of each motion against real time")
@click.option("--volume", type=float, default=0.5, show_default=True,
              help="arm-pouring: the liquid in the robot's bottle, in litres")
@click.option("--liquid-seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="arm-pouring: the seed that draws the liquid's particles")
@click.option("--loopback-only", is_flag=True,
              help="advertise and send on 127.0.0.1 only (the DDS sockets still bind to 0.0.0.0)")
def serve_cmd(task: str, domain_id: int, speed: float, volume: float, liquid_seed: int, loopback_only: bool) -> None:
    """Serve TASK's simulated arm as a ROS 2 robot (a joint_trajectory_controller, /joint_states,
    /clock and the task's sensor: the landing camera or the glass's scale) until interrupted.
    """
    require("cyclonedds", "dmprs robot serve")
    # here, not at the top: it loads cyclonedds and the arm tasks, which no other command needs
    from dmprs.ros2.served import CONTROLLER, LANDING_TOPIC, SCALE_TOPIC, serve

    def ready() -> None:
        sensor = LANDING_TOPIC if task == "arm-throwing" else SCALE_TOPIC
        click.echo(f"{task}: serving {CONTROLLER}/follow_joint_trajectory, /joint_states, /clock and "
                   f"{sensor} on ROS domain {domain_id}; Ctrl-C stops", err=True)

    try:
        served = serve(task, domain_id, speed=speed, on_ready=ready, loopback_only=loopback_only,
                       bottle_volume=volume, liquid_seed=liquid_seed)
    except KeyboardInterrupt:
        return
    except DmprsError as exc:
        raise click.ClickException(str(exc)) from None
    click.echo(f"served {served} goal(s)", err=True)


@main.command("reproduce")
@click.option("--out", type=click.Path(path_type=Path), default=Path("out"), show_default=True,
              help="folder for report.md, report.json and the figures")
@click.option("--quick", is_flag=True, help="every part at small scale (about 20 s)")
@click.option("--backend", type=click.Choice(["local", "ray", "serial"]), default="local", show_default=True,
              help="local processes, a Ray cluster (RAY_ADDRESS or a local one), or in-process")
@click.option("--workers", type=int, default=None, help="parallel workers (default: all cores)")
@click.option("--update-docs", "docs_root", type=click.Path(path_type=Path, file_okay=False, exists=True),
              default=None, help="after a full run, rewrite the generated result tables of this checkout "
              "(README.md, docs/*.md) and store the summary they cite as docs/reproduction.json; after a "
              "--quick run, store its summary as docs/reproduction-quick.json")
@click.option("--check", "reference", type=click.Path(path_type=Path, dir_okay=False, exists=True), default=None,
              help="after the run, compare its summary with this stored one (docs/reproduction.json, or "
              "docs/reproduction-quick.json with --quick) bit for bit, timings aside; exit 1 naming the "
              "first difference")
def reproduce_cmd(out: Path, quick: bool, backend: str, workers: int | None, docs_root: Path | None,
                  reference: Path | None) -> None:
    """Run the paper's experiments in simulation and the baselines; write the report."""
    if docs_root is not None:
        try:
            docs_targets(docs_root, quick)  # before the run, not after an hour of it
        except InvalidInputError as exc:
            raise click.UsageError(str(exc)) from None
    import os

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn


    # Said before any work, not after minutes of it: what an optional package would add.
    for note in skipped(quick):
        click.echo(f"skipped: {note}", err=True)
    # MuJoCo's offscreen renderer (the arm's frame strip) needs a GL backend chosen before MuJoCo
    # is imported; EGL is headless. Without one the report says so in one line and carries on.
    os.environ.setdefault("MUJOCO_GL", "egl")

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), transient=False) as bar:
        job = bar.add_task("reproducing", total=None)

        def progress(done: int, total: int, result: dict) -> None:
            what = result.get("learner") or result.get("method")
            bar.update(job, completed=done, total=total,
                       description=f"{result['part']}: {what}".ljust(40)[:40])

        # Where the bar is not drawn (a log file, CI), one line per finished part instead of an
        # hour of silence.
        terminal = sys.stderr.isatty()

        def part_done(part: PartTime, elapsed: float, remaining: float) -> None:
            if not terminal:
                click.echo(f"finished {part.part}: {part.runs} run(s) at {elapsed / 60:.1f} min; about "
                           f"{remaining / 60:.0f} min left", err=True)

        try:
            report = reproduce(out, quick=quick, backend=backend, workers=workers, progress=progress,
                               part_done=part_done)
        except DmprsError as exc:
            raise click.ClickException(str(exc)) from None
    click.echo((out / "report.md").read_text())
    click.echo(f"finished in {report['seconds']} s; report and figures in {out}")
    if docs_root is not None:
        changed = update_docs(docs_root, report)
        click.echo(f"summary stored; tables rewritten in {', '.join(str(p) for p in changed) or 'no file'}")
    if reference is not None:
        try:
            check_summary(report, reference)
        except DmprsError as exc:
            raise click.ClickException(str(exc)) from None
        click.echo(f"the run reproduces {reference} bit for bit (timings aside)")


@main.command("demo")
@click.option("--out", type=click.Path(path_type=Path), default=Path("out"), show_default=True)
def demo_cmd(out: Path) -> None:
    """Fit, reproduce and adapt a 7-DOF DMP (a quick look at the core)."""
    demo.run(out)


if __name__ == "__main__":
    main()
