"""One change to the geometry-general end-state surrogate, measured alone: the shipped model fine-tuned on end-state
folders with one setting changed, for ``benchmarks/ood_surrogate.py --compare`` on the development seed.

    snakemake --cores 2 --configfile config/pretrain_general.yaml --directory work/pretrain_general \
        --until endstate_data results/model/endstate_history.csv
    python benchmarks/endstate_finetune.py --data work/pretrain_general/results/endstate/data --out work/variant

Each folder holds a set per subfolder (``<set>/chunk_*.h5``, as rule endstate_data writes them); each set's last 8
realizations are held out. Writes ``--out``.pt (checkpoints in ``--out``_ckpt: a killed run resumes). The
pipeline's own fine-tuning is ``endstate.model: finetune`` (config/pretrain_general_wide.yaml).
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from rgns.surrogates.endstate.data import read_end_states
from rgns.surrogates.endstate.model import load_model
from rgns.surrogates.endstate.train import EndStateTrainSettings, train

REPO = Path(__file__).resolve().parent.parent
HELD_OUT = 8


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", nargs="+", required=True, help="end-state folders")
    parser.add_argument("--start", default=str(REPO / "rgns" / "models" / "endstate_general.pt"))
    parser.add_argument("--steps", type=int, default=4000)
    parser.add_argument("--learning-rate", type=float, default=3e-4)
    parser.add_argument("--threshold-weight", type=float, default=0.02)
    parser.add_argument("--moved-head", action="store_true", help="add the moved / not-moved output")
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    states = read_end_states(sorted(path for folder in args.data for path in Path(folder).glob("*/chunk_*.h5")))
    last = {}
    for state in states:
        last[state.case] = max(last.get(state.case, 0), state.index)
    training = [s for s in states if s.index <= last[s.case] - HELD_OUT]
    held = [s for s in states if s.index > last[s.case] - HELD_OUT]
    start = load_model(args.start)
    settings = EndStateTrainSettings(
        widths=start.widths,
        steps=args.steps,
        batch_size=args.batch,
        learning_rate=args.learning_rate,
        threshold_weight=args.threshold_weight,
        moved_head=args.moved_head,
        checkpoint_every=500,
        seed=1,
    )
    logging.info("%d training and %d held-out realizations", len(training), len(held))
    model, history = train(training, held, start.lattice, settings, args.out + "_ckpt", start)
    model.save(args.out + ".pt", {"history": history})


if __name__ == "__main__":
    main()
