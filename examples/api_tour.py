# %% [markdown]
# # somite from Python: evolve a worm with ask/tell
#
# A notebook-style script (cells marked `# %%`, so editors can run it cell by cell). It runs
# the loop of `somite evolve` at a small size: 8 individuals, 3 generations, 5 s episodes.
# For the paper's settings use `population=96`, `duration=30.0` and a few thousand generations.
#
# Run it with `python examples/api_tour.py` (the test suite runs it too).

# %%
import numpy as np

import somite

POPULATION, GENERATIONS, DURATION = 8, 3, 5.0

# %% [markdown]
# A body is a shape (`worm`, `biped`, `WxH` or rows of 1/0) with the paper's sensors. The task
# owns the training terrains (a new random `hilly-1-10-SEED` per evaluation), the episode
# settings and the 10 fixed validation terrains. The EA only proposes genomes and ranks them.

# %%
body = somite.Body.build("worm")
task = somite.Locomotion(terrain="hilly-1-10-rnd", duration=DURATION)
ea = somite.GraphEA(body, population=POPULATION, seed=0)

# %% [markdown]
# Generation 0 is the initial population; each later one is n_pop offspring. The task draws
# its terrains and sensor noise from `ea.rng_evaluation`, a generator the mutations never use.

# %%
for _ in range(GENERATIONS):
    genomes = ea.ask()
    fitness = task.evaluate(genomes, rng=ea.rng_evaluation)  # v_x [m/s], shape (len(genomes),)
    row = ea.tell(genomes, fitness)
    print(f"generation {row['generation']}: best v_x {row['best_velocity']:.3f} m/s, "
          f"|G| {row['best_size']}")

# %% [markdown]
# The logged best is the best of many noisy draws (each genome met one random terrain), so
# re-run it on the fixed validation terrains before believing it.

# %%
validation = task.validate(ea.best)  # v_x [m/s] on hilly-1-10-10000 ... 10009, shape (10,)
print(f"logged best {ea.best_fitness:.3f} m/s; on the validation terrains "
      f"{somite.mean_velocity(validation):.3f} m/s (min {validation.min():.3f})")

# %%
outcome = somite.simulate(ea.best, terrain="flat", duration=DURATION)
print(f"on flat ground: v_x {outcome.velocity:.3f} m/s, {outcome.distance:.2f} m in total")

# %% [markdown]
# `ea.log` holds the rows `somite evolve` writes to `log.csv`; the command line is this loop
# plus a run directory (checkpoints, best genomes) and a validation every 50 generations.

# %%
assert [r["generation"] for r in ea.log] == list(range(GENERATIONS))
assert validation.shape == (10,) and np.isfinite(outcome.velocity)
