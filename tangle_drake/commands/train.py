"""``tangle-drake train``: train the tangle CNN on a collected dataset (resumable)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tangle_drake.commands.arguments import add_seed_argument


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "train", help="train the tangle CNN on a dataset from `tangle-drake collect`",
        description="Train the tangle CNN: 90/10 split by pile, classes balanced by "
                    "undersampling the majority class (a pick model's --objective weights "
                    "its loss by class instead: --balance), x8 rotation/flip augmentation, early "
                    "stopping on the validation loss. The network sees the depth crop and a "
                    "mask of the target part's pixels (--no-target-mask: the crop alone, as "
                    "in the paper). Writes OUT (best weights and the "
                    "configuration that made them), OUT's .state.pt (to resume) and .log.json "
                    "(per-epoch metrics). An interrupted run (Ctrl-C) continues from its last "
                    "finished epoch when the same command is run again.")
    parser.add_argument("--data", type=Path, required=True, help="dataset directory")
    parser.add_argument("--out", type=Path, required=True, help="checkpoint to write (.pt)")
    from tangle_drake.tangle_cnn.objectives import OBJECTIVES
    from tangle_drake.tangle_cnn.split import BALANCES
    from tangle_drake.tangle_cnn.train_settings import AUGMENTATIONS, TrainSettings

    default = TrainSettings()
    parser.add_argument("--epochs", type=int, default=default.epochs,
                        help=f"maximum epochs (default {default.epochs})")
    parser.add_argument("--batch-size", type=int, default=default.batch_size,
                        help=f"default {default.batch_size}")
    parser.add_argument("--lr", type=float, default=default.lr,
                        help=f"Adam learning rate ({default.lr:g})")
    add_seed_argument(parser, default.seed,
                      help=f"seed of the split, initial weights and shuffles (default "
                           f"{default.seed})")
    parser.add_argument("--patience", type=int, default=default.patience,
                        help=f"stop after this many epochs without a lower validation loss "
                             f"(default {default.patience})")
    parser.add_argument("--augment", choices=tuple(AUGMENTATIONS), default=default.augment,
                        help="d4 (default): the paper's x8, 4 rotations x mirror (the 90-degree "
                             "ones turn the closing direction vertical); none")
    parser.add_argument("--no-target-mask", dest="target_mask", action="store_false",
                        help="train on the depth crop alone (the paper's input), without the "
                             "channel marking the target part")
    parser.add_argument("--objective", choices=tuple(OBJECTIVES), default=default.objective,
                        help="tangled (default): the paper's tangle CNN, from the tangle "
                             "labels; success: the seed's success/failure baseline, from the "
                             "outcomes of physical picks (collect --label pick), ranked by "
                             "P(success) with the success-cnn rule; outcome: three classes "
                             "(one part, several, none) from the same data, picking with "
                             "success-harmonic (graspability and P(one part))")
    parser.add_argument("--balance", choices=BALANCES, default=None,
                        help="how the classes are evened out: undersample (the paper's: as "
                             "many of each class as the rarest has; the tangle CNN's default) "
                             "or weight (every sample, each class's loss weighted by the "
                             "inverse of its share; the pick models' default, whose rarest "
                             "class is a few dozen picks)")
    parser.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto",
                        help="auto: CUDA when available, else the CPU")
    parser.add_argument("--restart", action="store_true",
                        help="ignore OUT's saved training state and start over")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from tangle_drake.tangle_cnn.train import TrainSettings, state_path, train

    settings = TrainSettings(epochs=args.epochs, batch_size=args.batch_size, lr=args.lr,
                             seed=args.seed, patience=args.patience, augment=args.augment,
                             target_mask=args.target_mask, objective=args.objective,
                             balance=args.balance)
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
