"""``benchmarks/transfer.py``, the transfer check: the parts that need no Java on tiny runs made
here (which generations it samples, the driver's CSV, ratios and medians, the error lines), and
one end-to-end run that needs a build of the 2D-VSR-Sim driver (env ``VSR``). No timing."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from somite import evolve, resolve
from somite.errors import SomiteError
from somite.sim.terrain import parse_terrain
from somite.tasks.validation import evaluate

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import transfer  # noqa: E402

TINY = {"shape": "worm", "preset": "original-code", "population": 4, "generations": 4,
        "duration": 2.0, "validate_every": 0}
DRIVER_CSV = """\
sim,name,shape,terrain,sigma,hidden,vx,x_first,x_last,x_end,y_end,seconds
java,genome-00000,worm-6x2,flat,0.01,sigmoid,0.006114155,20.336530,20.489282,20.486839,8.08,3.885
java,genome-00000,worm-6x2,flat,0,sigmoid,0.023307202,20.416269,20.998560,21.000276,8.074112,3.479
java,genome-00001,worm-6x2,hilly-1-10-10000,0.01,sigmoid,NaN,20.1,20.2,20.2,8.0,1.5
"""
"""Shaped as CL.java writes it in ``genomes`` mode (as ``java-init-worm.csv``)."""


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A worm run of the driver's preset and a biped run of the paper preset."""
    root = tmp_path_factory.mktemp("transfer")
    evolve(resolve(TINY), root / "worm")
    evolve(resolve({**TINY, "shape": "biped", "preset": "paper", "seed": 1}), root / "biped")
    return root


def test_select_generations():
    assert transfer.select_generations(range(8), 3) == [0, 3, 6, 7]
    assert transfer.select_generations(range(7), 3) == [0, 3, 6]
    assert transfer.select_generations([0, 1, 2], 50) == [0, 2]
    assert transfer.select_generations([0], 50) == [0]
    assert transfer.select_generations([], 5) == []
    for every in (0, -1, 1.5, True):
        with pytest.raises(SomiteError, match=r"^every="):
            transfer.select_generations(range(3), every)


def test_load_run_picks_the_generations_best(runs):
    run = transfer.load_run(str(runs / "worm"), 3)
    assert [e["generation"] for e in run.entries] == [0, 3, 4]
    assert run.last == 4 and run.shape == "worm" and run.config.preset == "original-code"
    lines = [json.loads(line) for line in (runs / "worm/bests.jsonl").read_text().splitlines()]
    for entry in run.entries:
        assert entry["data"] == lines[entry["generation"]]["genome"]
        assert entry["velocity"] == lines[entry["generation"]]["velocity"]
    assert transfer.load_run(str(runs / "biped"), 50).shape == "biped"


def test_parse_driver_csv():
    cells = transfer.parse_driver_csv(DRIVER_CSV)
    assert cells[("genome-00000", "flat", 0.01)] == 0.006114155
    assert cells[("genome-00000", "flat", 0.0)] == 0.023307202
    assert math.isnan(cells[("genome-00001", "hilly-1-10-10000", 0.01)])
    assert len(cells) == 3
    with pytest.raises(SomiteError, match=r"^driver_csv=.*'vx'"):
        transfer.parse_driver_csv("sim,name,terrain,sigma\njava,a,flat,0.01\n")
    with pytest.raises(SomiteError, match=r"^driver_csv='row 2'"):
        transfer.parse_driver_csv(DRIVER_CSV.splitlines()[0] + "\njava,a,worm-6x2,flat,0.01,"
                                  "sigmoid,fast,0,0,0,0,0\n")


def test_sigma_as_the_driver_takes_it():
    assert transfer.sigma_text(0.01) == "0.01" and transfer.sigma_text(0.0) == "0"


def test_ratio_and_median():
    assert transfer.ratio(0.5, 2.0) == 0.25
    assert transfer.ratio(-0.1, 0.2) == pytest.approx(-0.5)
    for vsr, somite in ((1.0, 0.0), (math.nan, 1.0), (1.0, math.nan), (math.inf, 1.0)):
        assert math.isnan(transfer.ratio(vsr, somite))
    assert transfer.median([3.0, None, 1.0, math.nan, 2.0]) == 2.0
    assert transfer.median([1.0, 2.0]) == 1.5
    assert math.isnan(transfer.median([None, math.nan]))


def test_the_driver_runs_the_code_s_sensors_with_the_run_s_hidden_nodes(runs):
    worm, biped = (transfer.load_run(str(runs / name), 2).config for name in ("worm", "biped"))
    assert transfer.driver_config(worm) == transfer.sim_config(worm)  # original-code: itself
    paper, driven = transfer.sim_config(biped), transfer.driver_config(biped)
    assert paper.hidden_activation == driven.hidden_activation == "tanh"
    code = transfer.sim_config(worm)
    for name in ("lidar_angles", "lidar_frame", "touch_window", "velocity_window",
                 "velocity_frame", "noise_stream", "voxel_angle", "noise_sigma"):
        assert getattr(driven, name) == getattr(code, name), name
    assert dataclasses.replace(driven, hidden_activation="sigmoid") == code
    assert (driven.duration, driven.transient) == (30.0, 5.0)


def test_compare_ratios_medians_and_the_preset_mismatch(runs):
    terrains = [parse_terrain("flat"), parse_terrain("hilly-1-10-10000")]
    loaded = [transfer.load_run(str(runs / name), 2) for name in ("worm", "biped")]
    names, cells, own = {}, {}, {}
    for run in loaded:  # a fake 2D-VSR-Sim: half of somite's speed on the same sensors
        config = transfer.driver_config(run.config)
        genomes = [e["genome"] for e in run.entries]
        velocities = evaluate(genomes, terrains, config)
        own[run.shape] = evaluate(genomes, terrains, transfer.sim_config(run.config))
        for entry, row in zip(run.entries, velocities):
            key = transfer._key(entry["data"], config.hidden_activation)
            name = names.setdefault(key, f"genome-{len(names):05d}")
            for t, v in zip(terrains, row):
                cells[(name, t.name, 0.01)] = v / 2
    out = transfer.compare(loaded, terrains, cells, seed=0, start=2, names=names)
    worm, biped = out["runs"]
    assert [g["generation"] for g in worm["generations"]] == [0, 2, 4]
    assert not worm["preset_mismatch"] and biped["preset_mismatch"]
    assert (worm["hidden"], biped["hidden"]) == ("sigmoid", "tanh")
    assert worm["episode_mismatch"] and worm["episode"] == {"duration": 2.0, "transient": 5.0}
    assert worm["noise_sigma"] == 0.01
    for run in out["runs"]:
        for g, row in zip(run["generations"], own[run["shape"]]):
            assert g["vsr_vx"] == pytest.approx(g["somite_vx"] / 2)
            assert g["ratio"] == pytest.approx(0.5)
            assert g["somite_own_vx"] == float(transfer.mean_velocity(row))
            assert g["overall_ratio"] == pytest.approx(g["vsr_vx"] / g["somite_own_vx"])
            assert set(g["terrains"]) == {"flat", "hilly-1-10-10000"}
        assert run["median_ratio"] == pytest.approx(0.5)
        assert run["ratios_counted"] == 2 and run["ratios_left_out"] == 0  # generations 2, 4
    for g in worm["generations"]:  # its own sensors are the driver's
        assert g["somite_own_vx"] == g["somite_vx"] and g["overall_ratio"] == g["ratio"]
    assert out["shapes"]["worm"] == {"runs": 1, "median_ratio": pytest.approx(0.5),
                                     "median_overall_ratio": pytest.approx(0.5),
                                     "runs_preset_mismatch": 0}
    assert out["shapes"]["biped"]["runs"] == 1 and out["shapes"]["biped"][
        "runs_preset_mismatch"] == 1
    assert out["shapes"]["biped"]["median_ratio"] == pytest.approx(0.5)
    assert out["shapes"]["biped"]["median_overall_ratio"] == biped["median_overall_ratio"]
    # A genome the driver has no cell for is NaN there, and left out of the median.
    last = names[transfer._key(loaded[0].entries[-1]["data"], "sigmoid")]
    lost = [g for g, e in zip(worm["generations"], loaded[0].entries)
            if names[transfer._key(e["data"], "sigmoid")] == last and g["generation"] >= 2]
    kept = {k: v for k, v in cells.items() if k[0] != last}
    worm = transfer.compare(loaded[:1], terrains, kept, 0, 2, names)["runs"][0]
    assert worm["generations"][-1]["vsr_vx"] is None and worm["generations"][-1]["ratio"] is None
    assert worm["ratios_left_out"] == len(lost) and worm["ratios_counted"] == 2 - len(lost)


def test_own_sensors_drive_each_run_on_its_preset(runs):
    """``--sensors own``: the driver reads each run's own sensors, so somite runs each best
    once, on its own preset, and the ratio is the overall ratio."""
    loaded = [transfer.load_run(str(runs / name), 2) for name in ("worm", "biped")]
    for run, read in zip(loaded, ("code", "paper")):
        own = transfer.driver_config(run.config, "own")
        assert own == transfer.sim_config(run.config)
        assert transfer.driver_sensors(own, run.path) == read
    assert transfer.driver_sensors(transfer.driver_config(loaded[1].config)) == "code"
    odd = dataclasses.replace(transfer.sim_config(loaded[1].config), velocity_window=3)
    with pytest.raises(SomiteError, match="neither the paper preset's nor the original-code"):
        transfer.driver_sensors(odd, "somewhere")
    terrains = [parse_terrain("flat")]
    names, cells = {}, {}
    for run, read in zip(loaded, ("code", "paper")):  # a fake 2D-VSR-Sim: half of somite's
        config = transfer.driver_config(run.config, "own")
        velocities = evaluate([e["genome"] for e in run.entries], terrains, config)
        for entry, row in zip(run.entries, velocities):
            key = transfer._key(entry["data"], config.hidden_activation, read)
            name = names.setdefault(key, f"genome-{len(names):05d}")
            cells[(name, "flat", 0.01)] = row[0] / 2
    out = transfer.compare(loaded, terrains, cells, seed=0, start=2, names=names, sensors="own")
    for run, read in zip(out["runs"], ("code", "paper")):
        assert run["driver_sensors"] == read and not run["preset_mismatch"]
        assert run["median_ratio"] == run["median_overall_ratio"] == pytest.approx(0.5)
        for g in run["generations"]:
            assert g["somite_vx"] == g["somite_own_vx"] and g["ratio"] == g["overall_ratio"]
            assert g["vsr_vx"] == pytest.approx(g["somite_vx"] / 2)
    assert out["shapes"]["biped"]["runs_preset_mismatch"] == 0


def error_line(capsys, *argv: str) -> str:
    assert transfer.main(list(argv)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("transfer.py: error: "), err
    return err.removeprefix("transfer.py: error: ")


def test_a_packed_runs_thinned_bests_are_not_sampled(runs, tmp_path):
    """A run unpacked from ``somite campaign pack`` keeps a best every few generations: the
    thinned lines are skipped, the kept ones sampled (paper-rq1's ablation runs, carried in
    from a pack, were refused before)."""
    import shutil

    from somite.experiments.history import line_digest, thinned_line

    packed = tmp_path / "packed"
    shutil.copytree(runs / "worm", packed)
    lines = (packed / "bests.jsonl").read_text().splitlines()
    thin = [thinned_line(g, line_digest("bests", line)) if g in (1, 2, 3) else line
            for g, line in enumerate(lines)]
    (packed / "bests.jsonl").write_text("\n".join(thin) + "\n")
    run = transfer.load_run(str(packed), 3)
    assert [e["generation"] for e in run.entries] == [0, 4] and run.last == 4
    assert run.entries[1]["data"] == json.loads(lines[4])["genome"]
    (packed / "bests.jsonl").write_text("\n".join([*thin, thin[2]]) + "\n")
    with pytest.raises(SomiteError, match="generation 2 twice"):
        transfer.load_run(str(packed), 3)
    (packed / "bests.jsonl").write_text(thin[1] + "\n")
    with pytest.raises(SomiteError, match=r"every line thinned"):
        transfer.load_run(str(packed), 3)


def test_bad_run_directories(runs, tmp_path, capsys):
    vsr = ("--vsr", str(tmp_path))
    assert error_line(capsys, str(tmp_path / "none"), *vsr).startswith("run=")
    assert "no config.json" in error_line(capsys, str(tmp_path), *vsr)
    assert "a file" in error_line(capsys, str(runs / "worm/log.csv"), *vsr)
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "config.json").write_text((runs / "worm/config.json").read_text())
    (broken / "bests.jsonl").write_text("")
    assert "empty" in error_line(capsys, str(broken), *vsr)
    (broken / "bests.jsonl").write_text('{"generation": 0}\n')
    assert "no generation and genome" in error_line(capsys, str(broken), *vsr)
    (broken / "bests.jsonl").write_text("{not json\n")
    assert error_line(capsys, str(broken), *vsr).startswith("run=")
    (broken / "bests.jsonl").write_text((runs / "worm/bests.jsonl").read_text())
    (broken / "config.json").write_text('{"preset": "fast"}')
    assert error_line(capsys, str(broken), *vsr).startswith("run=")


def test_a_body_the_driver_cannot_build_is_refused(tmp_path, capsys):
    evolve(resolve({**TINY, "generations": 0, "sensors": "area"}), tmp_path / "run")
    message = error_line(capsys, str(tmp_path / "run"), "--vsr", str(tmp_path))
    assert message.startswith("run=") and "only the worm and the biped" in message


def test_missing_driver_build(runs, tmp_path, capsys, monkeypatch):
    run = str(runs / "worm")
    message = error_line(capsys, run, "--vsr", str(tmp_path / "none"))
    assert message.startswith(f"vsr='{tmp_path / 'none'}'") and "no such folder" in message
    message = error_line(capsys, run, "--vsr", str(tmp_path))
    assert message.startswith("vsr=") and "classes-main/CL.class" in message
    monkeypatch.delenv("VSR", raising=False)
    assert error_line(capsys, run).startswith("vsr=None: give --vsr PATH or set VSR")
    monkeypatch.setenv("PATH", str(tmp_path))  # a build, but no java
    for part in ("classes-main/CL.class", "classes-hmsr/it", "classes-dyn4j/org", "lib"):
        (tmp_path / part).mkdir(parents=True)
    assert error_line(capsys, run, "--vsr", str(tmp_path)).startswith("java='java': not found")
    for variant in ("classes-dyn4j-noccd", "../classes-dyn4j", ""):  # not in the build
        message = error_line(capsys, run, "--vsr", str(tmp_path), "--dyn4j", variant)
        assert message.startswith(f"dyn4j='{variant}'") and "dyn4j's classes" in message
    (tmp_path / "classes-dyn4j-noccd/org").mkdir(parents=True)
    message = error_line(capsys, run, "--vsr", str(tmp_path), "--dyn4j", "classes-dyn4j-noccd")
    assert message.startswith("java='java': not found")


def test_own_sensors_errors(runs, tmp_path, capsys, monkeypatch):
    """``--sensors own`` needs the variant driver and a run of either preset's sensors; each is
    a one-line error."""
    run, vsr = str(runs / "biped"), ("--vsr", str(tmp_path))
    for part in ("classes-main/CL.class", "classes-hmsr/it", "classes-dyn4j/org", "lib"):
        (tmp_path / part).mkdir(parents=True)
    message = error_line(capsys, run, *vsr, "--sensors", "own")
    assert message.startswith("sensors='own'") and "classes-main-sensors" in message
    with pytest.raises(SystemExit):  # argparse's one line
        transfer.main([run, *vsr, "--sensors", "paper"])
    assert "--sensors" in capsys.readouterr().err
    message = error_line(capsys, run, *vsr, "--sensors", "own", "--campaign", str(tmp_path))
    assert message.startswith("run=") and "not a task folder" in message  # before the driver
    real = transfer.sim_config  # a run's sensors neither preset's (no run option makes one yet)
    monkeypatch.setattr(transfer, "sim_config",
                        lambda config: dataclasses.replace(real(config), touch_window=2))
    message = error_line(capsys, run, *vsr, "--sensors", "own")
    assert message.startswith(f"run='{run}'") and "neither the paper preset's" in message
    monkeypatch.undo()
    with pytest.raises(SomiteError, match="sensors='both'"):
        transfer.transfer([run], sensors="both")


def test_other_bad_options(runs, tmp_path, capsys):
    run, vsr = str(runs / "worm"), ("--vsr", str(tmp_path))
    assert error_line(capsys, run, *vsr, "--terrains", "hilly-x").startswith("terrain=")
    assert error_line(capsys, run, *vsr, "--terrains", ",").startswith("terrains=")
    assert error_line(capsys, run, *vsr, "--every", "0").startswith("every=")
    assert error_line(capsys, run, *vsr, "--from", "-1").startswith("from=")
    assert error_line(capsys, run, *vsr, "--threads", "0").startswith("threads=")
    assert [t.name for t in transfer.parse_terrains("validation")][-1] == "hilly-1-10-10009"


VSR = os.environ.get("VSR")


@pytest.mark.skipif(not VSR or not (Path(VSR) / "classes-main/CL.class").exists(),
                    reason="needs a build of the 2D-VSR-Sim driver in env VSR")
@pytest.mark.skipif(not transfer.DEFAULT_EXPORT.exists(), reason="no export_genomes.py beside")
def test_end_to_end(runs):
    """A run of each preset: the driver runs each with its own hidden nodes, somite each on
    the driver's sensors and on its own."""
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks/transfer.py"), str(runs / "worm"),
                           str(runs / "biped"), "--every", "4", "--from", "0", "--terrains",
                           "flat"], capture_output=True, text=True, cwd=ROOT, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "sigmoid hidden nodes" in done.stderr and "tanh hidden nodes" in done.stderr
    out = json.loads(done.stdout)
    assert out["driver"]["hidden"] == ["sigmoid", "tanh"] and out["terrains"] == ["flat"]
    for run, name in zip(out["runs"], ("worm", "biped")):
        assert [g["generation"] for g in run["generations"]] == [0, 4]
        assert run["preset_mismatch"] == (name == "biped")
        loaded = transfer.load_run(str(runs / name), 4)
        genomes = [e["genome"] for e in loaded.entries]
        somite = evaluate(genomes, [parse_terrain("flat")], transfer.driver_config(loaded.config))
        own = evaluate(genomes, [parse_terrain("flat")], transfer.sim_config(loaded.config))
        for g, v, o in zip(run["generations"], somite[:, 0], own[:, 0]):
            assert g["somite_vx"] == v and g["somite_own_vx"] == o
            assert math.isfinite(g["vsr_vx"])
            assert g["ratio"] == pytest.approx(g["vsr_vx"] / g["somite_vx"])
        assert out["shapes"][name]["runs"] == 1


@pytest.mark.skipif(not VSR or not (Path(VSR) / "classes-main-sensors/CL.class").exists(),
                    reason="needs the paper-sensors driver in env VSR's classes-main-sensors")
@pytest.mark.skipif(not transfer.DEFAULT_EXPORT.exists(), reason="no export_genomes.py beside")
def test_end_to_end_on_own_sensors(runs):
    """``--sensors own``: the variant driver reads each run's own sensors; somite runs each
    best on its own preset only."""
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks/transfer.py"), str(runs / "worm"),
                           str(runs / "biped"), "--every", "4", "--from", "0", "--terrains",
                           "flat", "--sensors", "own"], capture_output=True, text=True, cwd=ROOT,
                          timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "code sensors" in done.stderr and "paper sensors" in done.stderr
    out = json.loads(done.stdout)
    assert out["driver"]["sensors"] == "own" and out["driver"]["main"] == "classes-main-sensors"
    assert out["driver"]["sensors_read"] == ["code", "paper"]
    for run, name, read in zip(out["runs"], ("worm", "biped"), ("code", "paper")):
        assert run["driver_sensors"] == read and not run["preset_mismatch"]
        loaded = transfer.load_run(str(runs / name), 4)
        own = evaluate([e["genome"] for e in loaded.entries], [parse_terrain("flat")],
                       transfer.sim_config(loaded.config))
        for g, o in zip(run["generations"], own[:, 0]):
            assert g["somite_vx"] == g["somite_own_vx"] == o and math.isfinite(g["vsr_vx"])
            assert g["ratio"] == g["overall_ratio"] == pytest.approx(g["vsr_vx"] / o)


def test_campaign_rows_feed_the_reports_transfer_section(tmp_path, capsys):
    """``--campaign``: each run's last sampled generation into the campaign's transfer.csv,
    merged by task and engine, read back by the report's transfer section."""
    from somite.report.markdown import _transfer
    from somite.report.transfer import read_transfer

    campaign = tmp_path / "c"
    runs = [campaign / "rq1" / "worm-s0", campaign / "rq1" / "worm-s1"]

    def out(ratios):
        return {"runs": [{"run": str(run), "generations": [
            {"generation": 0, "somite_vx": 1.0, "vsr_vx": 9.0, "ratio": 9.0},
            {"generation": 3000, "somite_vx": 2.0, "vsr_vx": r and 2.0 * r, "ratio": r,
             "somite_own_vx": 4.0, "overall_ratio": r and r / 2}]}
            for run, r in zip(runs, ratios)]}

    assert transfer.engine_of("classes-dyn4j-noccd") == "noccd"
    assert transfer.engine_of("classes-dyn4j") == "stock"
    campaign.mkdir()
    transfer.write_campaign_csv(campaign, transfer.campaign_rows(out([0.5, 0.7]), campaign,
                                                                 "stock"))
    transfer.write_campaign_csv(campaign, transfer.campaign_rows(out([0.9, None]), campaign,
                                                                 "noccd"))
    transfer.write_campaign_csv(campaign, transfer.campaign_rows(out([0.6, 0.8]), campaign,
                                                                 "stock"))  # replaces
    transfer.write_campaign_csv(campaign, transfer.campaign_rows(out([0.95, 1.0]), campaign,
                                                                 "stock", "own"))  # beside
    lines = (campaign / "transfer.csv").read_text().splitlines()
    assert lines[0] == ("task,engine,sensors,generation,somite_vx,vsr_vx,ratio,somite_own_vx,"
                        "overall_ratio")
    assert lines[1:] == ["rq1/worm-s0,noccd,code,3000,2.0,1.8,0.9,4.0,0.45",
                         "rq1/worm-s0,stock,code,3000,2.0,1.2,0.6,4.0,0.3",
                         "rq1/worm-s0,stock,own,3000,2.0,1.9,0.95,4.0,0.475",
                         "rq1/worm-s1,noccd,code,3000,2.0,,,4.0,",
                         "rq1/worm-s1,stock,code,3000,2.0,1.6,0.8,4.0,0.4",
                         "rq1/worm-s1,stock,own,3000,2.0,2.0,1.0,4.0,0.5"]
    with pytest.raises(SomiteError, match="not a task folder"):
        transfer.campaign_rows({"runs": [{"run": str(tmp_path), "generations": [{}]}]},
                               campaign, "stock")
    tasks = {"rq1/worm-s0": ("rq1", "worm"), "rq1/worm-s1": ("rq1", "worm")}
    found = read_transfer(campaign, tasks)
    summary = {(s["engine"], s["sensors"]): s for s in found["summary"]}
    assert summary["stock", "code"]["median_ratio"] == pytest.approx(0.7)
    assert summary["stock", "code"]["median_overall_ratio"] == pytest.approx(0.35)
    assert summary["stock", "own"]["median_ratio"] == pytest.approx(0.975)
    assert (summary["noccd", "code"]["median_ratio"],
            summary["noccd", "code"]["not_finite"]) == (0.9, 1)
    text = "\n".join(_transfer({"transfer": found}))
    assert "| rq1 | worm | stock | code | 2 | 0.700 | 0.350 | 0 |" in text
    assert ("| rq1/worm-s0 | stock | code | 3000 | 4.000 | 2.000 | 1.200 | 0.600 | 0.300 |"
            in text)
    # a file written before the sensors and the last two columns: the code's sensors, n/a
    (campaign / "transfer.csv").write_text("task,engine,generation,somite_vx,vsr_vx,ratio\n"
                                           "rq1/worm-s0,stock,3000,2.0,1.2,0.6\n")
    old = read_transfer(campaign, tasks)
    assert old["summary"][0]["median_overall_ratio"] is None
    assert old["summary"][0]["sensors"] == "code"
    assert ("| rq1/worm-s0 | stock | code | 3000 | n/a | 2.000 | 1.200 | 0.600 | n/a |"
            in "\n".join(_transfer({"transfer": old})))
    transfer.write_campaign_csv(campaign, transfer.campaign_rows(out([0.95, 1.0]), campaign,
                                                                 "stock", "own"))
    lines = (campaign / "transfer.csv").read_text().splitlines()  # the old row kept, as code
    assert lines[1] == "rq1/worm-s0,stock,code,3000,2.0,1.2,0.6,,"
    (campaign / "transfer.csv").write_text("task,engine,sensors,ratio\nrq1/worm-s0,stock,paper,1\n")
    with pytest.raises(SomiteError, match="sensors='paper'"):
        read_transfer(campaign, tasks)
    assert "Not measured" not in text
    missing = read_transfer(tmp_path, tasks)
    assert "Not measured yet" in "\n".join(_transfer({"transfer": missing}))
    (campaign / "transfer.csv").write_text("task,engine,ratio\nrq1/worm-s0,fast,1\n")
    with pytest.raises(SomiteError, match="engine='fast'"):
        read_transfer(campaign, tasks)
