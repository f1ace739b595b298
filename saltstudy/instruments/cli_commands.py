"""The instruments' commands: ``saltstudy bench flow|particles|scene|profile`` and ``saltstudy probe
loglaw``."""
from __future__ import annotations

import json

import typer

from ..workflow.cli_commands import fail


def register(app: typer.Typer) -> None:
    bench_app = typer.Typer(no_args_is_help=True, help="Solver benchmarks (wall time per step).")

    @bench_app.command("flow")
    def flow(steps: int = typer.Option(10, "--steps", help="timed steps per grid (median reported)"),
             big: bool = typer.Option(True, "--big/--no-big", help="include the paper's grid (200x150x100)"),
             as_json: bool = typer.Option(False, "--json", help="one JSON object on stdout"),
             closure: list[str] = typer.Option(["deardorff"], "--closure",
                                               help="SGS closure (closure.model); repeat to compare"),
             advection_order: list[int] = typer.Option(
                 [2], "--advection-order",
                 help="horizontal advection order (time.advection_order); repeat to compare"),
             precision: list[str] = typer.Option(
                 None, "--precision", help="the flow's floating type (time.precision: single or "
                 "double; default the fidelity's); repeat to compare"),
             vertical_diffusion: list[str] = typer.Option(
                 None, "--vertical-diffusion", help="time.vertical_diffusion (explicit or implicit; "
                 "default the fidelity's); repeat to compare"),
             fidelity: list[str] = typer.Option(
                 None, "--fidelity", help="the fidelity whose grid is timed (default: reduced and, "
                 "with --big, paper); repeat for several"),
             against: str = typer.Option(None, "--against", help="git revision to time this "
                                         "checkout against, alternating rounds, each in its own process"),
             rounds: int = typer.Option(None, "--rounds", help="alternating rounds, each in its own "
                                        "process (--against: default 7; otherwise default 1, all in "
                                        "this process)")) -> None:
        """Median wall time per LES step on the reduced grid and the paper's, per cell-step, vs the FFT floor."""
        from .bench import bench_flow, format_report
        from ..solver.flow.advection import ADVECTION_ORDERS
        from ..solver.flow.stepper import PRECISIONS
        from ..solver.flow.vertical_diffusion import VERTICAL_DIFFUSION
        from ..solver.closures.closure import CLOSURES
        for opt, vals, known in (("--precision", precision, tuple(PRECISIONS)),
                                 ("--vertical-diffusion", vertical_diffusion, VERTICAL_DIFFUSION),
                                 ("--closure", closure, tuple(CLOSURES)),
                                 ("--advection-order", advection_order, tuple(ADVECTION_ORDERS))):
            bad_v = [x for x in vals or () if x not in known]
            if bad_v:
                fail(f"{opt}: unknown value {bad_v[0]!r} (known: {', '.join(map(str, known))})")
        if against:
            from .bench import compare_flow
            from .revision import RevisionError
            if (len(advection_order) > 1 or closure != ["deardorff"] or precision
                    or vertical_diffusion or fidelity):
                fail("--against: compares one configuration (Deardorff, one --advection-order, "
                     "the fidelities' precision and scheme)")
            try:
                compare_flow(against, steps=steps, rounds=7 if rounds is None else rounds, big=big,
                             advection_order=advection_order[0], as_json=as_json)
            except (RevisionError, ValueError) as e:
                raise typer.BadParameter(str(e), param_hint="--against") from e
            return
        res = bench_flow(steps, big, tuple(closure), tuple(advection_order),
                         tuple(precision or (None,)), tuple(vertical_diffusion or (None,)),
                         fidelity or None, 1 if rounds is None else rounds)
        typer.echo(json.dumps(res) if as_json else format_report(res))

    from .bench_particles import register_bench
    register_bench(bench_app)
    from .bench_scene import register_bench_scene
    register_bench_scene(bench_app)
    from .kernel_profile import register_bench_profile
    register_bench_profile(bench_app)
    app.add_typer(bench_app, name="bench")
    from .loglaw_probe import register_probe
    register_probe(app)
