"""``uvms study``: a Monte Carlo study of a scenario from the command line (:mod:`uvms.scenario.studies.study`)."""

from __future__ import annotations

import argparse
import sys

from ..errors import UVMSError
from .run import package_path_overrides
from .terminal import say


def command_study(options: argparse.Namespace) -> int:
    """``uvms study SCENARIO --samples KEY=DIST ... -n N --seed S``: study.csv, summary.json, figures (each flag
    named as the ``[study]`` key it sets)."""
    from ..scenario.studies.study import study  # joblib, scipy, and dask only with --backend dask

    result = study(options.scenario, options.samples or None, n=options.n, seed=options.seed,
                   method=options.method, jobs=options.jobs, backend=options.backend, scheduler=options.scheduler,
                   out=options.out, progress=False if options.quiet else None,
                   overrides=[*(options.set or ()), *package_path_overrides(options)],
                   insecure_scheduler=options.insecure_scheduler)
    rate = result.summary["pass_rate"]
    folder = result.files[0].parent
    say(f"pass rate   {rate['passed']}/{rate['trials']} = {rate['rate']:.1%} (95 % Wilson interval "
        f"{rate['ci_low']:.1%} to {rate['ci_high']:.1%})", sys.stdout)
    for metric in result.metrics:
        numbers = result.summary["metrics"][metric]
        if numbers:
            say(f"{metric:<26} median {numbers['p50']:.4g}  p95 {numbers['p95']:.4g}  max {numbers['max']:.4g}",
                sys.stdout)
    for outcome in (result.metrics[0], "pass") if result.metrics else ():
        shown = ", ".join(f"{e['key']} {e['eta2']:.2f}" if e["eta2"] is not None else f"{e['key']} const."
                          for e in result.summary["sensitivity"][outcome])
        say(f"sensitivity of {outcome} (eta^2, noise floor {result.summary['eta2_noise_floor']:.2f}): {shown}",
            sys.stdout)
    resumed = f"; {result.resumed} trials were already done (resumed)" if result.resumed else ""
    say(f"outputs     {folder}/ ({', '.join(path.name for path in result.files)}, trials/){resumed}", sys.stdout)
    failed = result.summary["failed_trials"]
    if failed:
        first = next(row for row in result.rows if row["error"])
        raise UVMSError(f"{len(failed)} of {len(result.rows)} trials failed (error column of {result.files[0]}); "
                        f"trial {first['trial']}: {first['error']}")
    return 0


def command_tune(options: argparse.Namespace) -> int:
    """``uvms tune SCENARIO --param KEY=LOW:HIGH[:log] ... --objective METRIC|pass_rate --trials N``."""
    from ..scenario.studies.tune import tune  # optuna

    result = tune(options.scenario, options.param or (), objective=options.objective, trials=options.trials,
                  seed=options.seed, samples=options.samples or (), study_n=options.study_n,
                  study_seed=options.study_seed, jobs=options.jobs, backend=options.backend,
                  scheduler=options.scheduler, out=options.out,
                  overrides=[*(options.set or ()), *package_path_overrides(options)],
                  insecure_scheduler=options.insecure_scheduler)
    best = result.best
    failed = sum(1 for row in result.rows if row["error"])
    say(f"best        {best['objective']} = {best['value']:.6g} (trial {best['trial']} of {len(result.rows)}"
        f"{f', {failed} failed' if failed else ''})", sys.stdout)
    say(f"--set       {' '.join(best['set'])}", sys.stdout)
    folder = result.files[0].parent
    say(f"outputs     {folder}/ ({', '.join(path.name for path in result.files)}, trials/)", sys.stdout)
    return 0
