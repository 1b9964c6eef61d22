"""Issue 72, beyond the paper: edges delayed by their length, and an edge addition biased
against long edges. Both off by default, with every number of the paper's runs unchanged.

The delayed graph is checked against a NumPy reference on every backend: the CPU lanes, the
stepper (somite.Episode) and the CUDA kernel (numba-cuda's simulator, in a process of its own).
"""

from __future__ import annotations

import hashlib
import json
import math
import warnings
from dataclasses import replace

import numpy as np

from somite.brain.compile import compile_genome
from somite.brain.delays import (
    MAX_EDGE_DELAY,
    delays,
    edge_delays,
    edge_lengths,
    length_counts,
    longest_delay,
)
from somite.brain.genome import Genome, body_table
from somite.brain.kinds import ACTUATOR, HIDDEN, RELAY, SENSOR
from somite.campaigns.builtin import builtin
from somite.campaigns.expansion import expand
from somite.cli import main
from somite.evolution.ea import GraphEA
from somite.evolution.operators import OperatorConfig, add_edge, initial_genome, mutate
from somite.experiments.config import resolve
from somite.experiments.runner import run_fingerprint
from somite.modules.reassembly import reassemble
from somite.sim.body import Body
from somite.sim.partition import Partition
from somite.sim.terrain import parse_terrain
from somite.tasks.locomotion import simulate_batch
from somite.tasks.stepper import Episode

from . import delay_batch
from .backend_batch import run_elsewhere
from .conftest import expect_error


def _tanh(x: float) -> float:
    # The kernels' tanh (somite._math), written out: the reference must agree to the bit.
    e = math.exp(-2.0 * abs(x))
    return math.copysign((1.0 - e) / (1.0 + e), x)


def reference_actuation(genome: Genome, readings: np.ndarray) -> np.ndarray:
    """The delayed graph run on ``readings`` (K + 1, R), row k read at control step k: the
    actuation (K + 1, V) of steps 0..K. Node values kept for every step, h_j = 0 for j <= 0;
    a node sums h_{k - D}(source) * w + b over its edges in the genome's order, D the edge's
    delay computed here from its voxels, not by somite.brain.delays."""
    index, table = genome.index, body_table(genome.body)
    xy = table.voxel_xy[index.voxel].astype(float)
    s = genome.delay_per_voxel
    lag = [min(MAX_EDGE_DELAY, max(1, math.ceil(s * math.dist(xy[u], xy[v]) - 1e-9)))
           for u, v in zip(index.src.tolist(), index.dst.tolist())]
    steps = readings.shape[0] - 1
    h = np.zeros((steps + 1, genome.n_nodes))
    actuation = np.zeros((steps + 1, genome.body.shape.n_voxels))
    reading = table.first_reading[index.voxel] + index.slot
    for k in range(1, steps + 1):
        total = [0.0] * genome.n_nodes
        for e, edge in enumerate(genome.edges):
            u, v = index.src[e], index.dst[e]
            total[v] += h[max(k - lag[e], 0), u] * edge.weight + edge.bias
        for n in range(genome.n_nodes):
            kind = index.kind[n]
            h[k, n] = _tanh(readings[k, reading[n]] if kind == SENSOR else total[n])
            if kind == ACTUATOR:
                actuation[k, index.voxel[n]] = h[k, n]
    return actuation


# -- the law ------------------------------------------------------------------------------------


def test_delay_grows_with_length_one_step_at_least_and_sixty_at_most():
    lengths = np.array([0.0, 1.0, math.sqrt(2), 2.0, math.sqrt(5), 10.0, 1e6])
    assert delays(lengths, 0.0).tolist() == [1] * 7  # the paper's
    assert delays(lengths, 1.0).tolist() == [1, 1, 2, 2, 3, 10, MAX_EDGE_DELAY]
    assert delays(lengths, 0.7).tolist() == [1, 1, 1, 2, 2, 7, MAX_EDGE_DELAY]
    assert delays(lengths, 2.5).tolist() == [1, 3, 4, 5, 6, 25, MAX_EDGE_DELAY]


def test_edge_lengths_and_their_distribution():
    genome = delay_batch.grown("biped", 6, 1.0)
    lengths = edge_lengths(genome)
    xy = {n.id: (n.x, n.y) for n in genome.nodes}
    assert lengths.tolist() == [math.dist(xy[e.src], xy[e.dst]) for e in genome.edges]
    counts = length_counts([genome, genome])
    assert sum(counts.values()) == 2 * genome.n_edges and list(counts) == sorted(counts)
    assert counts[0.0] == 2 * int((lengths == 0).sum()) and max(counts) <= math.sqrt(13) + 1e-3
    assert longest_delay(1.0, genome.body.shape) == 4 and longest_delay(0.0, genome.body.shape) == 1


def test_a_delayed_genome_compiles_to_relay_chains_and_saves_its_delay():
    paper = delay_batch.grown("worm", 3, 0.0)
    delayed = replace(paper, delay_per_voxel=1.0)
    plain, relayed = compile_genome(paper), compile_genome(delayed)
    extra = int((edge_delays(delayed) - 1).sum())
    assert extra > 20 and edge_delays(paper).tolist() == [1] * paper.n_edges
    assert (relayed.n_nodes, relayed.n_edges) == (paper.n_nodes + extra, paper.n_edges + extra)
    assert (relayed.node_kind[paper.n_nodes:] == RELAY).all()
    n = paper.n_edges  # the genome's edges keep their rows; only the long ones' sources move
    for name in ("dst", "weight", "bias"):
        assert np.array_equal(getattr(relayed, name)[:n], getattr(plain, name))
    long = edge_delays(delayed) > 1
    assert np.array_equal(relayed.src[:n][~long], plain.src[~long])
    assert (relayed.src[:n][long] >= paper.n_nodes).all()
    # A genome without delays: its file and arrays as they always were.
    assert "delay_per_voxel" not in paper.to_dict() and '"delay_per_voxel"' not in \
        paper.to_compact()
    assert paper.n_nodes == plain.n_nodes and paper.n_edges == plain.n_edges
    for text in (delayed.to_compact(), json.dumps(delayed.to_dict())):
        again = Genome.from_compact(text)
        assert again == delayed and again.delay_per_voxel == 1.0 and again != paper
    expect_error("delay_per_voxel", lambda: replace(paper, delay_per_voxel=-1.0))
    expect_error("delay_per_voxel", lambda: replace(paper, delay_per_voxel=math.inf))


# -- every backend against the reference ----------------------------------------------------------


def test_cpu_lanes_and_stepper_run_the_delayed_graph_of_the_reference():
    delayed = delay_batch.genomes()
    config = delay_batch.batch(delayed)[2].with_options(duration=0.5)
    bodies = [g.body for g in delayed]
    terrains = ["hilly-1-10-7", "hilly-1-10-8"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # uint64 hashing wraps
        worlds = [parse_terrain(t) for t in terrains]
        _, lanes = simulate_batch(bodies, worlds, [compile_genome(g) for g in delayed], config,
                                  delay_batch.SEEDS, record=True)
        stepped = Episode(delayed, terrains, config, delay_batch.SEEDS, record=True).run()
        _, undelayed = simulate_batch(
            bodies, worlds, [compile_genome(replace(g, delay_per_voxel=0.0)) for g in delayed],
            config, delay_batch.SEEDS, record=True)
    assert all(np.array_equal(a, b, equal_nan=True) for a, b in zip(lanes, stepped))
    for b, genome in enumerate(delayed):
        v = genome.body.shape.n_voxels
        expected = reference_actuation(genome, lanes.readings[b][:, :genome.body.n_readings])
        assert np.array_equal(lanes.actuation[b][:, :v], expected)
        # The delays matter: the same graph without them acts otherwise from step 2 on.
        assert not np.array_equal(undelayed.actuation[b][:3, :v], lanes.actuation[b][:3, :v])


def test_the_cuda_kernel_runs_the_delays_as_the_cpu(tmp_path):
    """Under numba-cuda's simulator (CI has no GPU), in a process of its own."""
    out = run_elsewhere("tests.delay_batch", "cuda", tmp_path / "cuda.npz")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        cpu = delay_batch.trace_of("cpu", delay_batch.genomes())
        undelayed = delay_batch.trace_of("cpu", delay_batch.genomes(0.0))
    with np.load(out) as cuda:
        assert cuda["status"].tolist() == cpu.status.tolist() == [0, 0]
        for field in ("com", "min_area", "max_speed"):
            assert np.abs(cuda[field] - getattr(cpu, field)).max() < 1e-9, field
    # The delays matter within these 6 steps: the voxels squeezed otherwise without them.
    assert np.abs(undelayed.min_area - cpu.min_area).min() > 1e-4


# -- the distance bias --------------------------------------------------------------------------


def test_add_edge_draws_pairs_with_weight_exp_minus_bias_times_distance():
    parent = delay_batch.grown("worm", 3, 0.0)  # hidden nodes: pairs inside a voxel too
    body = parent.body
    rng = np.random.default_rng(1)
    draws = 1500
    lengths = []
    for _ in range(draws):
        child = add_edge(parent, rng, distance_bias=1.0)
        lengths.append(edge_lengths(child)[-1])
    # Expected share of pairs at most a voxel apart: their weight over all candidates'.
    index, table = parent.index, body_table(body)
    xy = table.voxel_xy[index.voxel].astype(float)
    allowed = (index.kind != ACTUATOR)[:, None] & (index.kind != SENSOR)[None, :]
    allowed[index.src, index.dst] = False
    np.fill_diagonal(allowed, False)
    d = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1))
    weight = np.where(allowed, np.exp(-d), 0.0)
    share = weight[d <= 1].sum() / weight.sum()
    seen = np.mean(np.array(lengths) <= 1)
    assert abs(seen - share) < 4 * math.sqrt(share * (1 - share) / draws)
    uniform = np.mean(d[allowed] <= 1)
    assert share > 2 * uniform  # the bias is visible beside the paper's uniform draw


def test_without_the_new_options_the_draws_and_fingerprints_are_the_papers():
    """Digests taken with somite before issue 72 (commit d543c42): 400 mutations of each
    shape under the default operators and under omega 10, and the fingerprints of two runs."""
    before = {
        "worm": "145d649033e8ec22b721ef164e7e77d91c05bda64f924307571f53ef7301a124",
        "biped": "39810f5e2ee1a78f64bd48b835eebffe42da077e15155fdf2a365d97e7902082",
        "{}": "1e89135cb3817b31a7829a99d115a66690b90f66fcd93f5c7dccf11b3f56d41b",
        '{"shape": "biped", "omega": 10.0}':
            "2a7e60516eb728fb61fc3a322e20af8e77936b68e6139fa4d950583c0d22f604",
    }
    for shape, omega in (("worm", 1.0), ("biped", 10.0)):
        body = Body.build(shape)
        rng = np.random.default_rng(7)
        config = OperatorConfig(omega=omega)
        partition = Partition.parse("paper", body.shape) if omega != 1.0 else None
        genome, names = initial_genome(body, rng), []
        for _ in range(400):
            genome, name = mutate(genome, rng, config, partition)
            names.append(name)
        text = genome.to_compact() + ",".join(names)
        assert hashlib.sha256(text.encode()).hexdigest() == before[shape]
    for options in ({}, {"shape": "biped", "omega": 10.0}):
        config = resolve(options)
        assert run_fingerprint(config, config.body()) == before[json.dumps(options)]
        assert not {"distance_bias", "delay_per_voxel"} & set(config.to_dict())


# -- options, the EA, reassembly ------------------------------------------------------------------


def test_the_options_reach_the_genomes_through_toml_and_the_command_line(tmp_path):
    toml = tmp_path / "run.toml"
    toml.write_text("delay_per_voxel = 1.0\ndistance_bias = 0.5\n")
    out = tmp_path / "run"
    assert main(["evolve", "--config", str(toml), "--population", "4", "--generations", "1",
                 "--duration", "0.2", "--validate-every", "0", "--out", str(out),
                 "--quiet"]) == 0
    saved = json.loads((out / "config.json").read_text())
    assert (saved["delay_per_voxel"], saved["distance_bias"]) == (1.0, 0.5)
    assert Genome.load(out / "best.json").delay_per_voxel == 1.0
    assert main(["evolve", "--delay-per-voxel", "11", "--out", str(tmp_path / "no")]) == 2
    expect_error("distance_bias", lambda: resolve({"distance_bias": -1.0}))
    expect_error("delay_per_voxel", lambda: resolve({"delay_per_voxel": "one"}))
    ea = GraphEA(Body.build("biped"), 4, delay_per_voxel=2.0, distance_bias=1.0)
    assert {g.delay_per_voxel for g in ea.ask()} == {2.0}
    assert ea.config.operators.distance_bias == 1.0
    start = initial_genome(Body.build("biped"), np.random.default_rng(0))
    expect_error("delay_per_voxel",
                 lambda: GraphEA(start.body, 4, start=start, delay_per_voxel=1.0))


def test_reassembly_keeps_the_donors_delays_and_refuses_to_mix_them():
    halves = Partition.preset("worm-halves", "worm")
    one, two = delay_batch.grown("worm", 4, 1.0), delay_batch.grown("worm", 5, 1.0)
    parts = {"back": (one, halves, "back"), "front": (two, halves, "front")}
    result = reassemble(one.body, halves, parts)
    assert result.genome.delay_per_voxel == 1.0
    assert compile_genome(result.genome).n_nodes > result.genome.n_nodes  # relays: long edges
    mixed = {"back": (one, halves, "back"),
             "front": (replace(two, delay_per_voxel=0.0), halves, "front")}
    expect_error("donors", lambda: reassemble(one.body, halves, mixed))
    assert {n.kind for n in result.genome.nodes} <= {"sensor", "hidden", "actuator"}
    assert HIDDEN in result.genome.index.kind


# -- the comparison campaign --------------------------------------------------------------------


def test_the_lengths_campaign_compares_the_three_eas_and_their_reassemblies():
    tasks = {t["id"]: t for t in expand(builtin("lengths"))}
    assert len(tasks) == 3 * 6 * 3  # 3 EAs x 6 runs, each run's reassembly and re-optimisation
    for experiment, key in (("distance-bias", "distance_bias"), ("length-delay",
                                                                 "delay_per_voxel")):
        assert tasks[f"{experiment}/worm-s2"]["options"][key] == 1.0
        reopt = tasks[f"{experiment}-homo/biped-s2+s0-reopt"]["options"]
        assert reopt[key] == 1.0 and reopt["generations"] == 34
        assert key not in tasks["neutral/worm-s2"]["options"]
    assert tasks["neutral/biped-s0"]["options"]["generations"] == 200
    assert tasks["neutral/biped-s0"]["options"]["population"] == 32


def test_a_campaign_of_delayed_runs_reassembles_and_reoptimises_them(tmp_path, capsys):
    """The ``lengths`` campaign's delayed experiment and its reassembly at the smoke budget
    (one shape, two seeds: ``lengths-smoke`` whole takes minutes), from a campaign file."""
    smoke = builtin("lengths-smoke")
    runs = next(e for e in smoke.experiments if e.name == "length-delay")
    defaults = ", ".join(f"{k} = {v}" for k, v in smoke.defaults.items())
    (tmp_path / "delays.toml").write_text(f"""
title = "length-dependent delays, reassembled"
validation = {smoke.validation}
defaults = {{ {defaults} }}
[experiments.length-delay]
kind = "evolve"
shapes = ["worm"]
seeds = 2
options = {{ delay_per_voxel = {runs.settings["options"]["delay_per_voxel"]} }}
[experiments.length-delay-homo]
kind = "reassemble"
donors = "length-delay"
pairing = "next"
reoptimize = {{ generations = 1 }}
""")
    out = tmp_path / "lengths"
    assert main(["campaign", "run", str(tmp_path / "delays.toml"), "--out", str(out),
                 "--workers", "1", "--threads", "1", "--quiet"]) == 0, capsys.readouterr().err
    assert json.loads((out / "length-delay" / "worm-s0" / "config.json").read_text())[
        "delay_per_voxel"] == 1.0
    delayed = Genome.load(out / "length-delay-homo" / "worm-s1+s0" / "reassembled.json")
    assert delayed.delay_per_voxel == 1.0
    reopt = out / "length-delay-homo" / "worm-s1+s0-reopt"
    assert Genome.load(reopt / "best.json").delay_per_voxel == 1.0
    assert json.loads((reopt / "config.json").read_text())["delay_per_voxel"] == 1.0


def test_the_replay_pages_node_activity_follows_the_delays():
    from somite.viz.video import record_episode
    from somite.viz.replay import node_activity

    genome = delay_batch.grown("worm", 7, 1.0)
    recording = record_episode(genome.body, genome, "hilly-1-10-0",
                               delay_batch.batch([genome, genome])[2].with_options(duration=0.3),
                               seed=1)
    h = node_activity(genome, recording)
    index = genome.index
    actuators = np.flatnonzero(index.kind == ACTUATOR)
    np.testing.assert_allclose(h[1:, actuators], recording.actuation[1:, index.voxel[actuators]],
                               atol=1e-9)
    undelayed = node_activity(replace(genome, delay_per_voxel=0.0), recording)
    assert np.abs(undelayed[1:, actuators] - h[1:, actuators]).max() > 1e-3


def test_a_delayed_genome_is_not_exported_as_a_module(tmp_path, capsys):
    path = delay_batch.grown("worm", 8, 1.0).save(tmp_path / "delayed.json")
    assert main(["module", "export", str(path), "--module", "front",
                 "--partition", "worm-halves", "--out", str(tmp_path / "front.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "genome=" in err and "delay_per_voxel=1" in err and "\n" not in err
    assert not (tmp_path / "front.json").exists()
