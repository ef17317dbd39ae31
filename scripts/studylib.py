"""What the study summaries share (imported by the scripts beside it, run as scripts/<name>.py):
reading a run's JSON when it exists, and a column of seeds as mean ± sample std."""
import json
import os
import statistics


def load_json(path):
    """The JSON at `path`, or None when there is no such file (a run not finished yet)."""
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def mean_std(xs, digits):
    """`mean ± std` (sample std, n - 1) of the values that are not None, to `digits`
    decimals; one value as it is; none as "–"."""
    xs = [x for x in xs if x is not None]
    if not xs:
        return "–"
    if len(xs) == 1:
        return f"{xs[0]:.{digits}f}"
    return f"{statistics.mean(xs):.{digits}f} ± {statistics.stdev(xs):.{digits}f}"
