#!/usr/bin/env python3
"""Cost of equal accuracy in the identification study (PUB4's comparison).

Reads the results of pipelines/identification_comparison.yaml and prints, per
identify stage, the model evaluations it needed until its best point reached
a mean MAC (over the kept reference modes) of each threshold - from the
`mean_mac` column of history.csv - and the ratio of every black-box run's
count to the guided strategy's. "-" means not reached within the budget; the
ratio is then a lower bound (budget / guided count, written ">x").

The guided history starts after its subproblem step (every evaluation before
it is counted), so its counts include that step. The GSA screening (once per
model, reused by every later identification, PUB4) is listed separately.

    cargo run --release -- run pipelines/identification_comparison.yaml
    python3 benchmarks/identification_costs.py [results/identification_comparison]
"""
import csv
import json
import os
import sys

THRESHOLDS = [0.95, 0.96, 0.97, 0.99, 0.999, 0.9999]


def score_stage(stage):
    """The evaluate stage that scores identify stage `stage`."""
    if stage.startswith("guided["):
        return "score_" + stage
    if stage.startswith("black_box["):
        return "score_" + stage
    if stage == "black_box_slsqp":
        return "score_black_box_slsqp"
    return f"score_ablation[variant={stage}]"


def median(values):
    v = sorted(values)
    n = len(v)
    return (v[n // 2] + v[(n - 1) // 2]) / 2 if n else float("nan")


def parameter_errors(root, stage, stiffness, damping):
    """Median |relative error| over `stiffness` and over `damping` names."""
    path = os.path.join(root, score_stage(stage), "tables", "parameter_errors.csv")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        err = {r["parameter"]: abs(float(r["relative_error"])) for r in csv.DictReader(f)}
    return median([err[p] for p in stiffness]), median([err[p] for p in damping])


def first_reaching(history, threshold):
    with open(history) as f:
        for row in csv.DictReader(f):
            if float(row["mean_mac"]) >= threshold:
                return int(row["evaluation"])
    return None


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "results/identification_comparison"
    stages = sorted(
        d for d in os.listdir(root) if os.path.exists(os.path.join(root, d, "history.csv"))
    )
    rows = {}
    for stage in stages:
        with open(os.path.join(root, stage, "cost.json")) as f:
            cost = json.load(f)
        reached = [first_reaching(os.path.join(root, stage, "history.csv"), t) for t in THRESHOLDS]
        rows[stage] = (cost, reached)
    with open(os.path.join(root, "gsa", "subproblems.json")) as f:
        gsa = json.load(f)
    with open(os.path.join(root, "truth", "parameters.csv")) as f:
        kinds = {r["parameter"]: r["kind"] for r in csv.DictReader(f)}
    stiffness = [p for p in gsa["significant"] if kinds[p] == "stiffness"]
    with open(os.path.join(root, "guided[scenario=truth]", "subproblems.json")) as f:
        damping = json.load(f)["damping_parameters"]
    print(f"GSA screening: {gsa['evaluations']} evaluations (once per model)")
    print(f"{len(stiffness)} significant stiffness parameters; {len(damping)} damping parameters fitted\n")
    header = ["stage", "evaluations", "seconds", "mean MAC", "mean NFD", "mean NDD"]
    header += ["median stiffness error", "median damping error"]
    header += [f"to MAC {t}" for t in THRESHOLDS]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for stage, (cost, reached) in rows.items():
        m = cost["modes"]
        cells = [
            stage,
            str(cost["evaluations"]),
            f"{cost['seconds']:.1f}",
            f"{m['mean_mac']:.6f}",
            f"{m['mean_nfd']:.2e}",
            f"{m['mean_ndd']:.2e}",
        ]
        errors = parameter_errors(root, stage, stiffness, damping)
        cells += ["-", "-"] if errors is None else [f"{e:.2e}" for e in errors]
        cells += ["-" if r is None else str(r) for r in reached]
        print("| " + " | ".join(cells) + " |")
    guided = rows.get("guided[scenario=truth]")
    if guided is None:
        return
    print("\nEvaluations relative to guided[scenario=truth] at equal MAC:")
    for stage, (cost, reached) in rows.items():
        if not stage.startswith("black_box"):
            continue
        ratios = []
        for g, b in zip(guided[1], reached):
            if g is None:
                ratios.append("n/a")
            elif b is None:
                ratios.append(f">{cost['evaluations'] / g:.1f}")
            else:
                ratios.append(f"{b / g:.2f}")
        print(f"  {stage}: " + ", ".join(f"MAC {t}: {r}" for t, r in zip(THRESHOLDS, ratios)))


if __name__ == "__main__":
    main()
