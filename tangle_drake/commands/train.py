"""``tangle-drake train``: train the tangle CNN on a collected dataset (resumable)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "train", help="train the tangle CNN on a dataset from `tangle-drake collect`",
        description="Train the tangle CNN: 90/10 split by pile, classes balanced by "
                    "undersampling the majority class, x8 rotation/flip augmentation, early "
                    "stopping on the validation loss. Writes OUT (best weights and the "
                    "configuration that made them), OUT's .state.pt (to resume) and .log.json "
                    "(per-epoch metrics). An interrupted run (Ctrl-C) continues from its last "
                    "finished epoch when the same command is run again.")
    parser.add_argument("--data", type=Path, required=True, help="dataset directory")
    parser.add_argument("--out", type=Path, required=True, help="checkpoint to write (.pt)")
    parser.add_argument("--epochs", type=int, default=30, help="maximum epochs (default 30)")
    parser.add_argument("--batch-size", type=int, default=64, help="default 64")
    parser.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (1e-3)")
    parser.add_argument("--seed", type=int, default=0,
                        help="seed of the split, initial weights and shuffles (default 0)")
    parser.add_argument("--patience", type=int, default=5,
                        help="stop after this many epochs without a lower validation loss")
    parser.add_argument("--augment", choices=("d4", "none"), default="d4",
                        help="d4 (default): the paper's x8, 4 rotations x mirror (the 90-degree "
                             "ones turn the closing direction vertical); none")
    parser.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto",
                        help="auto: CUDA when available, else the CPU")
    parser.add_argument("--restart", action="store_true",
                        help="ignore OUT's saved training state and start over")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from tangle_drake.tangle_cnn.train import TrainSettings, state_path, train

    settings = TrainSettings(epochs=args.epochs, batch_size=args.batch_size, lr=args.lr,
                             seed=args.seed, patience=args.patience, augment=args.augment)
    try:
        metrics = train(args.data, args.out, settings, device=args.device,
                        restart=args.restart, log=tqdm.write)
    except KeyboardInterrupt:
        saved = state_path(args.out)
        print(f"interrupted; the last finished epoch is saved in {saved}: run the same command "
              "again to continue" if saved.exists() else "interrupted before the first epoch "
              "finished; nothing saved", file=sys.stderr)
        return 130
    print(f"wrote {args.out}: epoch {metrics['epoch']}, validation loss "
          f"{metrics['val_loss']:.4f}, accuracy {metrics['val_accuracy']:.3f}")
    return 0
