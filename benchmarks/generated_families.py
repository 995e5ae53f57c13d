"""docs/generated_families.png: six draws of each generated family of config/pretrain_general.yaml.

python benchmarks/generated_families.py
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from rgns.config import load_config  # noqa: E402
from rgns.scene.geometry import build_scene  # noqa: E402

config = load_config("config/pretrain_general.yaml")
families = {n: f for n, f in config["geometry"]["families"].items() if "generator" in f}
figure, axes = plt.subplots(len(families), 6, figsize=(15, 1.0 + 1.1 * len(families)), sharex=True, sharey=True)
geometry = {k: config["geometry"][k] for k in ("runout_room_m", "max_draws")}
for row, (name, family) in enumerate(families.items()):
    for col in range(6):
        scene = build_scene(
            name, col, name, family, config["domain"], config["mesh"], geometry, config["endstate"]["data_seed"]
        )
        v = np.vstack([scene.vertices, scene.vertices[:1]])
        axes[row, col].fill(v[:, 0], v[:, 1], color="tan", edgecolor="saddlebrown")
        axes[row, col].set_xlim(0, 80)
        axes[row, col].set_ylim(0, 20)
        axes[row, col].set_aspect("equal")
    axes[row, 0].set_ylabel(name.replace("gen_", ""), fontsize=9)
figure.suptitle("Generated families (realizations 0-5 of endstate.data_seed); domain 80 x 20 m", fontsize=10)
figure.tight_layout()
figure.savefig("docs/generated_families.png", dpi=80)
