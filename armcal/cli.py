"""Command line: thin wrappers over the library (contract in docs/architecture.md)."""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Callable
from contextlib import contextmanager
from functools import wraps
from pathlib import Path
from typing import Annotated

import typer
from typer.core import TyperArgument, TyperCommand

from armcal import __version__
from armcal.support.process_end import end_without_final_collection
from armcal.support.errors import UserError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    rich_markup_mode=None,  # plain click-style help: no <bool> after every flag
    context_settings={"help_option_names": ["-h", "--help"]},
)


class Command(TyperCommand):
    """A command whose help names arguments as click does: SPEC, [SPEC], SPEC... (typer writes {spec}, <list[Path]>)."""

    def collect_usage_pieces(self, ctx: typer.Context) -> list[str]:
        arguments = [_argument_name(p) for p in self.get_params(ctx) if isinstance(p, TyperArgument)]
        return [self.options_metavar, *arguments] if self.options_metavar else arguments

    def format_options(self, ctx: typer.Context, formatter) -> None:
        rows = {"Arguments": [], "Options": []}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None and isinstance(param, TyperArgument):
                rows["Arguments"].append((_argument_name(param), record[1]))
            elif record is not None:
                rows["Options"].append(record)
        for title, records in rows.items():
            if records:
                with formatter.section(title):
                    formatter.write_dl(records)


def _argument_name(argument: TyperArgument) -> str:
    name = (argument.metavar or argument.name.upper()) + ("..." if argument.nargs != 1 else "")
    return name if argument.required else f"[{name}]"


def _print_version(value: bool) -> None:
    if value:
        typer.echo(__version__)
        raise typer.Exit()


@app.callback()
def main(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True, help="Print armcal's version and exit.")] = False,
) -> None:
    """Kinematic calibration of robot arms."""
    end_without_final_collection()  # one command per process: its objects go back to the system at exit


SpecArg = Annotated[Path, typer.Argument(help="Calibration spec (YAML).", metavar="SPEC", show_default=False)]


def file_name(value: str) -> Path:
    """An output file's name as typed: a name ending in a separator names a folder, and no file is written there."""
    if value.endswith((os.sep, "/")):
        raise typer.BadParameter(f"'{value}' ends in '/', which names a folder: give the name of the file to write")
    return Path(value)


def user_errors(command: Callable) -> Callable:
    """Print a user error as one clear message and exit 1, without a traceback."""

    @wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except UserError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(1) from None

    return wrapper


@app.command(cls=Command)
def validate(
    specs: Annotated[list[Path], typer.Argument(help="Calibration specs (YAML).", metavar="SPEC", show_default=False)],
) -> None:
    """Check specs; list every problem with file, line, column and field (exit 1 if any spec has one).

    Warnings (exit 0 all the same): data files not there yet, stand-ins armcal new or import-urdf wrote that are
    unchanged (spec placeholders), a target on the axis of the joint it rides on.
    """
    from armcal.spec.axis_warnings import axis_warnings
    from armcal.spec import load_spec
    from armcal.spec.loader import missing_data_files
    from armcal.spec.placeholders import placeholder_warnings
    from armcal.commands.terminal import spec_summary

    failed = False
    for spec in specs:
        try:
            loaded = load_spec(spec)
        except UserError as exc:
            typer.echo(f"error: {exc}", err=True)
            failed = True
            continue
        typer.echo(spec_summary(loaded))
        for issue in [*missing_data_files(loaded), *placeholder_warnings(loaded), *axis_warnings(loaded)]:
            typer.echo(f"warning: {issue}", err=True)
    if failed:
        raise typer.Exit(1)


@app.command(cls=Command)
def schema(
    markdown: Annotated[bool, typer.Option("--markdown", help="The spec reference as Markdown (docs/spec-reference.md) instead.")] = False,
) -> None:
    """Print the JSON Schema of specs (for editor completion and checks)."""
    if markdown:
        from armcal.spec.reference import reference_markdown, shipped_specs

        typer.echo(reference_markdown(shipped_specs()), nl=False)
        return
    from armcal.spec.schema import spec_json_schema

    typer.echo(json.dumps(spec_json_schema(), indent=2))


@app.command(cls=Command)
@user_errors
def fk(
    spec: SpecArg,
    q: Annotated[str, typer.Option(help="Joint values in the spec's units, comma separated.", metavar="VALUES")],
    target: Annotated[str | None, typer.Option(help="A robot target instead of the tool.", metavar="NAME")] = None,
) -> None:
    """Forward kinematics of the spec's nominal robot at one configuration."""
    from armcal.commands.terminal import forward_kinematics_report
    from armcal.spec import load_spec

    typer.echo(forward_kinematics_report(load_spec(spec), q, target))


@app.command(cls=Command)
@user_errors
def simulate(
    spec: SpecArg,
    out: Annotated[Path | None, typer.Option("--out", help="Folder for the CSV files and truth.json (default: where the spec's data section points, so that `armcal run` reads them).", metavar="DIR")] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace existing data files and truth.json.")] = False,
) -> None:
    """Write the spec's calibration and validation data, measured on a simulated true robot."""
    from armcal.support.progress import stage
    from armcal.simulate import data_folder, write_simulation
    from armcal.spec import load_spec
    from armcal.commands.terminal import simulation_summary, where_run_reads

    loaded = load_spec(spec)
    with stage("simulating the campaign"):
        campaign, written = write_simulation(loaded, out if out is not None else data_folder(loaded), force)
    for path in written:
        typer.echo(f"wrote {path}")
    typer.echo(simulation_summary(loaded, campaign))
    typer.echo(where_run_reads(loaded, written))


HistoryOption = Annotated[
    list[Path] | None,
    typer.Option("--history", help="An earlier calibration of the same robot (a results.json or a run's folder), for the certificate's history; repeatable.", metavar="PATH"),
]


@app.command(cls=Command)
@user_errors
def run(
    spec: SpecArg,
    out: Annotated[Path | None, typer.Option("--out", help="Output folder (default: out/<spec stem>/ beside the spec).", metavar="DIR")] = None,
    no_pdf: Annotated[bool, typer.Option("--no-pdf", help="Skip the PDF certificate.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Replace an existing certificate and its whole output set.")] = False,
    history: HistoryOption = None,
) -> None:
    """Identify the robot from the spec's data and write results.json and calibrated.yaml."""
    from armcal.commands.run import run as run_pipeline
    from armcal.commands.terminal import run_summary

    outcome = run_pipeline(spec, out, force, pdf=not no_pdf, history=history or [])
    typer.echo(run_summary(outcome))
    raise typer.Exit(outcome.exit_code)


@app.command(cls=Command)
@user_errors
def report(
    results: Annotated[Path, typer.Argument(help="A results.json written by armcal run, or the output folder that holds it.", metavar="RESULTS", show_default=False)],
    no_pdf: Annotated[bool, typer.Option("--no-pdf", help="Write only certificate.html.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Replace the existing certificate.")] = False,
    history: HistoryOption = None,
) -> None:
    """Render the certificate again from results.json alone (and the plots beside it, and earlier results given)."""
    from armcal.support.progress import stage
    from armcal.report.render import rerender

    with stage("rendering the certificate" + ("" if no_pdf else " (PDF)")):
        written = rerender(results, pdf=not no_pdf, force=force, history=history or [])
    for path in written:
        typer.echo(f"wrote {path}")


WorkersOption = Annotated[int | None, typer.Option("--workers", help="Local worker processes, 1 to 256 (default: one per core).", metavar="N")]
SchedulerOption = Annotated[
    str | None, typer.Option("--scheduler", help="Run on a Dask distributed cluster: its scheduler's address, e.g. tcp://10.0.0.5:8786.", metavar="ADDRESS")
]


@app.command(cls=Command)
@user_errors
def montecarlo(
    spec: SpecArg,
    runs: Annotated[int, typer.Option("--runs", help="Simulated robots per point (Stone used 500).", metavar="N", min=2, max=100_000)] = 500,
    sweep: Annotated[
        list[str] | None,
        typer.Option("--sweep", help="Vary one input: noise_factor=1,2,5,10 | points_per_joint=20,40,60,80,100 | target_radius=30,40,50 | sigma_e=0.1,0.3,0.5 (spec units).", metavar="NAME=VALUES"),
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of the study's robots (default: the spec's simulate.seed).", metavar="N", min=0)] = None,
    out: Annotated[Path | None, typer.Option("--out", help="Output folder (default: out/<spec stem>/montecarlo/ beside the spec).", metavar="DIR")] = None,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    poses: Annotated[
        str | None,
        typer.Option("--poses", help="Also predict held-out accuracy for these numbers of calibration poses, planned vs random (e.g. 15,30,60).", metavar="N,N,..."),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace an earlier study in the output folder (the whole folder's set).")] = False,
) -> None:
    """Stone's Monte-Carlo study: N simulated robots identified, then design-model vs calibrated control on the grid task."""
    from armcal.commands.montecarlo import montecarlo as run_study, pose_counts
    from armcal.commands.terminal import study_summary

    with _progress_bar("robots, then designs") as show:
        study = run_study(spec, runs, sweep or [], seed, out, workers, scheduler, show, pose_counts(poses), force)
    typer.echo(study_summary(study))


@contextmanager
def _progress_bar(what: str):
    """A progress bar on stderr (rich); yields show(done, total)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    columns = (TextColumn(what), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn())
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(what, total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


@app.command(cls=Command)
@user_errors
def batch(
    specs: Annotated[list[Path], typer.Argument(help="Calibration specs (YAML), one robot each.", metavar="SPEC", show_default=False)],
    out: Annotated[Path | None, typer.Option("--out", help="Folder for all outputs, one subfolder per spec (default: each spec's out/<stem>/).", metavar="DIR")] = None,
    no_pdf: Annotated[bool, typer.Option("--no-pdf", help="Skip the PDF certificates.")] = False,
    force: Annotated[bool, typer.Option("--force", help="Replace existing certificates.")] = False,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
) -> None:
    """Calibrate a fleet: run every spec (one certificate each) in parallel; exit 1 if any spec failed, 4 on an internal error."""
    from armcal.commands.batch import batch as run_batch, exit_code, summary_files, write_summary
    from armcal.support.fileio import refuse_replacing
    from armcal.commands.terminal import batch_summary

    summary = summary_files(out)
    refuse_replacing(summary, specs, force)  # before the fleet's work, not after it
    with _progress_bar("specs") as show:
        outcomes = run_batch(specs, out, force, not no_pdf, workers, scheduler, show)
    table = batch_summary(outcomes)
    write_summary(summary, outcomes, table)
    typer.echo(table + f"\n  wrote {', '.join(str(p) for p in summary)}")
    raise typer.Exit(exit_code(outcomes))


@app.command("import-ipa", cls=Command)
@user_errors
def import_ipa(
    spec: SpecArg,
    source: Annotated[Path, typer.Argument(help="An ipa-robot-accuracy measurements file (';', decimal commas).", metavar="SERIES", show_default=False)],
    out: Annotated[Path, typer.Option("--out", help="The contract CSV to write.", metavar="FILE", parser=file_name)],
    target: Annotated[str, typer.Option(help="The robot target the tracker measured.", metavar="NAME")] = "tmac",
    force: Annotated[bool, typer.Option("--force", help="Replace an existing data file.")] = False,
) -> None:
    """Convert a public UR10 laser-tracker series into a data file of the spec (its units)."""
    from armcal.dataio.ipa import read_ipa
    from armcal.dataio.writer import write_measurements
    from armcal.support.fileio import refuse_replacing
    from armcal.spec import load_spec

    refuse_replacing([out], [spec, source], force)
    loaded = load_spec(spec)
    if target not in loaded.spec.robot.targets:
        raise UserError(f"{spec}: the robot has no target '{target}'")
    device = loaded.spec.device
    if not device.reads_positions or target not in device.seen_targets():
        raise UserError(f"{spec}: the ipa-robot-accuracy files are laser-tracker readings of one target; the spec's device must "
                        f"be a tracker measuring '{target}'")
    measurements = read_ipa(source, target, device.sees_orientation())
    write_measurements(out, measurements, loaded.spec)
    typer.echo(f"wrote {out}: {len(measurements)} samples")


@app.command(cls=Command)
@user_errors
def new(
    robot: Annotated[str | None, typer.Option("--robot", help="A library robot (see --list), e.g. ur5e.", metavar="NAME")] = None,
    device: Annotated[str | None, typer.Option("--device", help="The instrument's device.type (docs/devices/README.md lists them; an unknown one is answered with the list).", metavar="TYPE")] = None,
    out: Annotated[Path | None, typer.Option("--out", help="The spec to write (default: <robot>-<device>.yaml here).", metavar="SPEC", parser=file_name)] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace an existing spec.")] = False,
    list_robots: Annotated[bool, typer.Option("--list", help="List the library's robots and exit.")] = False,
) -> None:
    """Write a commented starting spec for a library robot and a measuring device (docs/robots.md)."""
    from armcal.support.fileio import refuse_replacing, write_text_atomic
    from armcal.devices.registry import INSTRUMENTS
    from armcal.commands.new import default_out, design_check, new_spec_text
    from armcal.robot_library import library_robot, names

    if list_robots:
        for name in names():
            typer.echo(f"{name:24s} {library_robot(name).robot.name}")
        return
    if robot is None or device is None:
        raise UserError("give --robot NAME and --device TYPE (or --list for the robots)")
    if device not in INSTRUMENTS:
        raise UserError(f"unknown device '{device}'; choose one of {', '.join(INSTRUMENTS)}")
    entry = library_robot(robot)
    path = out or default_out(entry.name, device)
    refuse_replacing([path], [], force)
    text = new_spec_text(entry, device, path.stem)
    write_text_atomic(path, text)
    typer.echo(f"wrote {path}: {entry.robot.name}, {device}; check it with `armcal validate {path}`")
    typer.echo("checking the starting design (armcal plan's information at the design model) ...", err=True)
    check = design_check(text, path)
    typer.echo(f"design: {check.describe()}")
    if not check.well_posed:
        typer.echo(f"warning: {path}'s calibration poses do not determine this robot: raise their count, or plan them with "
                   f"`armcal plan {path}`, before measuring", err=True)


UNREACHABLE = 3  # compensate's exit code when a target is unreachable (as run's 3: output written, the job not done)
CalibratedArg = Annotated[Path, typer.Argument(help="A calibrated spec (a run's calibrated.yaml) or a run's output folder.", metavar="CALIBRATED", show_default=False)]
OutFileOption = Annotated[Path, typer.Option("--out", help="The file to write.", metavar="FILE", parser=file_name)]
ForceOption = Annotated[bool, typer.Option("--force", help="Replace an existing file.")]


def _calibration_inputs(source: Path) -> list[Path]:
    """The files a calibration source is read from: never replaced by an export."""
    return [source, source / "calibrated.yaml", source / "results.json"] if source.is_dir() else [source]


@app.command(cls=Command)
@user_errors
def export(
    source: CalibratedArg,
    fmt: Annotated[str, typer.Option("--format", help="urdf, ur-calibration, dh-table or json.", metavar="FORMAT")],
    out: OutFileOption,
    force: ForceOption = False,
) -> None:
    """Write a calibration in a format other tools read (docs/export.md)."""
    from armcal.export import export as export_calibration
    from armcal.support.fileio import refuse_replacing, write_text_atomic

    refuse_replacing([out], _calibration_inputs(source), force)
    exported = export_calibration(source, fmt)
    write_text_atomic(out, exported.text)
    typer.echo(f"wrote {out} ({fmt})")
    if exported.left_out:
        typer.echo(f"  not held by {fmt} (calibrated.yaml keeps them): {', '.join(exported.left_out)}")
        typer.echo(f"  a program carries them all: armcal compensate {source} --targets TARGETS.csv --out COMMANDS.csv (docs/deploy.md)")
    if exported.learned:
        typer.echo(f"  {exported.learned} (docs/export.md)")


@app.command(cls=Command)
@user_errors
def compensate(
    source: CalibratedArg,
    targets: Annotated[Path, typer.Option("--targets", help="CSV of targets: name, x, y, z, rx, ry, rz (spec units), optional seeds q1..qn.", metavar="TARGETS")],
    out: OutFileOption,
    force: ForceOption = False,
    allow_unreachable: Annotated[bool, typer.Option("--allow-unreachable", help="Exit 0 even when a target is unreachable.")] = False,
) -> None:
    """Joint commands that reach Cartesian targets on the calibrated robot, its effects included (docs/export.md).

    Exit 3 when a target is unreachable: its row says why, and every other row is written all the same.
    """
    from armcal.export import calibration_source
    from armcal.export.compensation import compensate as compensated_commands
    from armcal.dataio.reader import data_text
    from armcal.report.numbers import counted
    from armcal.support.fileio import refuse_replacing, write_text_atomic

    refuse_replacing([out], [*_calibration_inputs(source), targets], force)
    loaded, results = calibration_source(source)
    text = data_text(targets)
    commands, unreached, left_out, learned = compensated_commands(loaded, results, text, str(targets))
    write_text_atomic(out, commands)
    reached = sum(1 for _ in csv.reader(io.StringIO(commands))) - 1 - len(unreached)  # records, not lines: a quoted name may hold a line break
    typer.echo(f"wrote {out}: {counted(reached, 'target')} reached" + (f", {len(unreached)} not" if unreached else ""))
    for line in unreached:
        typer.echo(f"  unreachable: {line}")
    if left_out:
        typer.echo(f"  not compensated (they do not follow the joints alone): {', '.join(left_out)}")
    if learned is not None:
        typer.echo(f"  {learned} (docs/export.md)")
    if results is None:
        typer.echo("  no corrected Cartesian targets: they need the nominal model, in a run's results.json (give the run's folder)")
    if unreached and not allow_unreachable:
        raise typer.Exit(UNREACHABLE)


@app.command("import-urdf", cls=Command)
@user_errors
def import_urdf(
    source: Annotated[Path, typer.Argument(help="A URDF file (plain XML: expand a xacro file first).", metavar="URDF", show_default=False)],
    base: Annotated[str, typer.Option("--base", help="The link the chain starts from: the spec's world frame.", metavar="LINK")],
    tip: Annotated[str, typer.Option("--tip", help="The link the chain ends at: the spec's tool frame.", metavar="LINK")],
    out: Annotated[Path, typer.Option("--out", help="The spec (YAML) to write.", metavar="SPEC", parser=file_name)],
    force: Annotated[bool, typer.Option("--force", help="Replace an existing spec.")] = False,
    convention: Annotated[str | None, typer.Option("--convention", help="dh, mdh or six_parameter (default: the simplest the chain's axes allow).", metavar="CONVENTION")] = None,
) -> None:
    """A spec of a URDF's chain from one link to another, device and procedure to edit (docs/export.md)."""
    from armcal.support.fileio import refuse_replacing, write_text_atomic
    from armcal.importers.spec_text import imported_spec
    from armcal.importers.urdf import read_urdf

    refuse_replacing([out], [source], force)
    chain = read_urdf(source, base, tip)
    spec = imported_spec(chain, source.name, base, tip, convention)
    write_text_atomic(out, spec.text)
    typer.echo(f"wrote {out}: {len(chain.joints)} joints from '{base}' to '{tip}', {spec.convention}" + (f", fixed joints merged: {', '.join(chain.merged)}" if chain.merged else "")
               + "".join(f", mimic joints {', '.join(mimics)} replaced by {master}" for master, mimics in chain.mimicked))
    if spec.reason:
        typer.echo(f"  {spec.convention}, {spec.reason}")
    typer.echo(f"  its serial, target, device and procedure are stand-ins: replace them (armcal validate {out} lists them)")


@app.command(name="compare", cls=Command)
@user_errors
def compare_calibrations(
    old: Annotated[str, typer.Argument(help="The earlier calibration: a results.json, a run's folder, a calibrated spec, or SPEC@REV (a spec at a git revision).", metavar="OLD", show_default=False)],
    new: Annotated[str, typer.Argument(help="The later calibration of the same robot, in any of those forms.", metavar="NEW", show_default=False)],
) -> None:
    """Each parameter's change between two calibrations of one robot, in units of the combined uncertainty."""
    from armcal.results.compare import compare

    table, _ = compare(old, new)
    typer.echo(table, nl=False)


@app.command(cls=Command)
@user_errors
def plan(
    spec: SpecArg,
    poses: Annotated[int, typer.Option("--poses", help="Poses to plan.", metavar="N")],
    out: Annotated[Path, typer.Option("--out", help="The pose list to write (CSV: q1..qN in the spec's units); POSES.json beside it.", metavar="POSES", parser=file_name)],
    candidates: Annotated[int, typer.Option("--candidates", help="Random candidate poses to choose from.", metavar="M")] = 2000,
    extend: Annotated[Path | None, typer.Option("--extend", help="A pose list to keep and add N poses to.", metavar="CSV")] = None,
    runs: Annotated[int, typer.Option("--runs", help="Simulated robots that predict the held-out accuracy (0: none).", metavar="R")] = 50,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of the candidates and robots (default: the spec's simulate.seed).", metavar="N", min=0)] = None,
    criterion: Annotated[str | None, typer.Option("--criterion", help="D (log det of the information, the default) or I (average held-out prediction variance; the default with --region).", metavar="D|I")] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace existing POSES and POSES.json.")] = False,
    region: Annotated[str | None, typer.Option("--region", help="Predict and plan for the working region: iso_cube (the ISO 9283 cube) or grid (Stone's grid box).", metavar="iso_cube|grid")] = None,
    orientation: Annotated[str, typer.Option("--orientation", help="The region's poses: at the task's orientation (task, the default) or any.", metavar="task|any")] = "task",
) -> None:
    """Choose N calibration poses from M readable candidates (D-optimal), with predicted uncertainties and accuracy (docs/plan.md)."""
    from armcal.commands.plan import plan_command

    say = lambda line: typer.echo(line, err=True)  # noqa: E731
    with _progress_bar("robots") as show:
        result, written = plan_command(spec, poses, candidates, extend, out, force, runs, seed, criterion, show, say, region, orientation)
    typer.echo(result.text + f"\nwrote {', '.join(str(p) for p in written)}")


@app.command(cls=Command)
def version() -> None:
    """Print armcal's version."""
    typer.echo(__version__)
