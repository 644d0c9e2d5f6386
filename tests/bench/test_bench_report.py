"""The bench is not a test: this only checks that `manipdyn bench --quick` runs and writes a valid report."""
import json

from manipdyn.cli import main


def test_bench_quick_writes_a_valid_report(tmp_path, monkeypatch):
    from manipdyn.bench import sections
    monkeypatch.setattr(sections, "per_call", lambda f, repeat=1, min_time=0: (f(), 1e-6)[1])  # no timing loops
    assert main(["bench", "--quick", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "report.json").read_text())
    for key in ("machine", "latency", "closed_latency", "throughput", "scaling", "slopes", "reduced",
                "work_precision", "spm_drift", "hard_cases"):
        assert data[key], key
    assert all(r["err"] <= 1e-12 for r in data["latency"])      # errors are measured, not assumed
    assert data["closed_latency"][0]["err"] <= 1e-10
    text = (tmp_path / "report.md").read_text()
    assert "ratio" in text and "pin" in data["machine"]["versions"]
    assert (tmp_path / "scaling.png").stat().st_size > 1000
    assert (tmp_path / "work_precision.png").stat().st_size > 1000
    assert all(r["max_phi"] < 1e-6 for r in data["spm_drift"])
