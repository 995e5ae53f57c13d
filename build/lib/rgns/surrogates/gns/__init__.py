"""The graph network simulator: cell-list graphs (graph.py), the physics-agnostic network
(network.py), features / normalisation / integration (simulator.py), training data (data.py),
training (train.py) and batched rollout (rollout.py)."""
