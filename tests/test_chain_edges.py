"""``scripts/experiments/chain_edges.py``: the roadmaps' chain where the roadmap's edges are bounded."""

from __future__ import annotations

import re

import pytest
from conftest import load_script


@pytest.mark.experiments
def test_the_chain_is_measured_with_and_without_on_bounded_roadmaps(capsys):
    script = load_script("experiments/chain_edges")
    assert script.main(["--maps", "1", "--seeds", "1", "--edge", "6"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if "geomean" in line]
    assert [r.split()[0] for r in rows] == ["PRM", "PRM", "LazyPRM", "LazyPRM"]
    means = {(r.split()[0], r.split()[4]): float(re.search(r"geomean\s+([\d.]+)", r).group(1)) for r in rows}
    assert all("connected 1.00" in r for r in rows)
    assert means[("PRM", "64")] < means[("PRM", "0")]  # on the validation maps the chain joins within the edges


@pytest.mark.experiments
def test_a_bad_argument_is_refused_before_any_run(capsys):
    script = load_script("experiments/chain_edges")
    with pytest.raises(SystemExit) as e:
        script.main(["--edge", "0"])
    assert e.value.code == 2 and "--edge" in capsys.readouterr().err
