"""``ergopose models fetch | list | verify``: the 2D pose model cache."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ergopose.cli_progress import ProgressBars
from ergopose.errors import ErgoposeError, ModelError
from ergopose.pose.models import (
    DEFAULT_LANDMARK_MODEL,
    ENV_MODEL_DIR,
    ENV_NPM_REGISTRY,
    LANDMARK_MODELS,
    MODEL_CARDS,
    POSE_COMMAND_MODEL,
    NpmSource,
    corrupt_message,
    fetch_models,
    model_status,
    resolve_model_dir,
    sha256_file,
)
from ergopose.pose.onnx_models import OnnxPoseCard, load_onnx_card

USER_ONNX_FOLDER = "onnx"

HELP = f"""\
The 2D pose models live in a cache folder: --model-dir, else ${ENV_MODEL_DIR}, else
~/.cache/ergopose/models. The BlazePose models (Apache-2.0) come from two packages: the person
detector and the full landmark model from the mediapipe 0.10.14 wheel on PyPI (downloaded with
pip), the lite and heavy landmark models from the @mediapipe/pose 0.5.1675469404 package
tarball on the npm registry (downloaded over HTTPS; ${ENV_NPM_REGISTRY} names a mirror). Each
download is checked against its pinned digest and only the model files are kept, each checked
against its pinned SHA-256. 'ergopose assess' and 'ergopose pose' choose the landmark model with
--model {"|".join(LANDMARK_MODELS)} (default: {DEFAULT_LANDMARK_MODEL} for assess, {POSE_COMMAND_MODEL} for pose) and fetch it on
first use.
Your own ONNX models: put NAME.onnx and a card NAME.toml in the cache's '{USER_ONNX_FOLDER}'
folder (docs/models.md)."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "models",
        help="fetch, list and verify the 2D pose models",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = parser.add_subparsers(dest="models_action", metavar="ACTION", title="actions")

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--model-dir",
            metavar="DIR",
            help=f"model cache folder (default: ${ENV_MODEL_DIR} or ~/.cache/ergopose/models)",
        )

    fetch = actions.add_parser("fetch", help="download the models (pip, npm registry) and check them")
    common(fetch)
    fetch.add_argument(
        "names", nargs="*", metavar="NAME", help=f"models to fetch (default: all: {', '.join(MODEL_CARDS)})"
    )
    fetch.add_argument("--force", action="store_true", help="download again even if the cached files are fine")
    fetch.add_argument(
        "--wheel", metavar="FILE", help="take the files from a local copy of the wheel instead of downloading"
    )
    fetch.add_argument(
        "--tarball",
        metavar="FILE",
        help="take the lite/heavy files from a local copy of the npm package tarball "
        "(npm pack @mediapipe/pose@0.5.1675469404) instead of downloading",
    )
    fetch.set_defaults(func=run_fetch)

    lst = actions.add_parser("list", help="show the model cards and what is in the cache")
    common(lst)
    lst.set_defaults(func=run_list)

    verify = actions.add_parser("verify", help="re-hash the cached files; fails on a missing or changed file")
    common(verify)
    verify.add_argument("names", nargs="*", metavar="NAME", help="models to verify (default: all)")
    verify.set_defaults(func=run_verify)

    parser.set_defaults(func=lambda args: _usage(parser))
    return parser


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 0


def run_fetch(args: argparse.Namespace) -> int:
    names = args.names or None
    paths = fetch_models(
        names, ProgressBars(), model_dir=args.model_dir, force=args.force, wheel=args.wheel, tarball=args.tarball
    )
    for path in paths:
        print(f"ok  {path}")
    return 0


def _user_cards(model_dir: Path) -> list[tuple[Path, OnnxPoseCard | ErgoposeError]]:
    """(card path, card or error) for every TOML card in the cache's onnx folder."""
    folder = model_dir / USER_ONNX_FOLDER
    out: list[tuple[Path, OnnxPoseCard | ErgoposeError]] = []
    for path in sorted(folder.glob("*.toml")) if folder.is_dir() else []:
        try:
            out.append((path, load_onnx_card(path)))
        except ErgoposeError as exc:
            out.append((path, exc))
    return out


def _user_state(card: OnnxPoseCard) -> str:
    if not card.file.is_file():
        return "missing"
    if card.sha256 is None:
        return "unpinned"
    return "ok" if sha256_file(card.file) == card.sha256 else "corrupt"


def _default_of(short: str) -> str:
    """Which commands use a landmark model when none is named."""
    users = [cmd for cmd, model in (("assess", DEFAULT_LANDMARK_MODEL), ("pose", POSE_COMMAND_MODEL)) if model == short]
    return f", the default of {' and '.join(users)}" if users else ""


def run_list(args: argparse.Namespace) -> int:
    model_dir = resolve_model_dir(args.model_dir)
    out = sys.stdout
    out.write(f"model cache: {model_dir}\n\n")
    for name, card in MODEL_CARDS.items():
        status = model_status(name, model_dir)
        w, h = card.input_size
        short = next((k for k, v in LANDMARK_MODELS.items() if v == name), None)
        label = f"  (--model {short}{_default_of(short)})" if short else ""
        out.write(f"{name}  [{status.state}]{label}\n")
        out.write(f"  {card.title}\n")
        out.write(f"  file     {status.path}\n")
        out.write(f"  sha256   {card.file.sha256}\n")
        kind = "package tarball (npm)" if isinstance(card.source, NpmSource) else "wheel (PyPI)"
        out.write(f"  source   {card.source.requirement} {kind}, {card.file.path_in_source}\n")
        out.write(f"  licence  {card.licence}\n")
        out.write(
            f"  input    {w} x {h} {card.channel_order}, range {card.normalisation.range[0]:g}..{card.normalisation.range[1]:g}\n"
        )
        schema = sum(i >= 0 for i in card.keypoint_schema)
        out.write(f"  output   {len(card.keypoint_names)} keypoints ({schema} in the ergopose schema)\n")
        if card.gates is not None:
            out.write(
                f"  gates    person when the pose flag >= {card.gates.min_presence:g}; keypoints steer the "
                f"next view when visibility >= {card.gates.min_keypoint_confidence:g}\n"
            )
        out.write("\n")
    for path, user_card in _user_cards(model_dir):
        if isinstance(user_card, ErgoposeError):
            out.write(f"{path.stem}  [invalid card]\n  {user_card}\n\n")
            continue
        w, h = user_card.input_size
        schema = sum(i >= 0 for i in user_card.schema_index)
        out.write(f"{user_card.name}  [{_user_state(user_card)}]  (your ONNX model)\n")
        out.write(
            f"  file     {user_card.file}\n  card     {path}\n  licence  {user_card.licence}\n  source   {user_card.source}\n"
        )
        out.write(f"  input    {w} x {h} {user_card.channel_order}\n")
        out.write(
            f"  output   {user_card.output_type}, {len(user_card.keypoint_names)} keypoints ({schema} in the ergopose schema)\n\n"
        )
    return 0


def run_verify(args: argparse.Namespace) -> int:
    model_dir = resolve_model_dir(args.model_dir)
    problems: list[ModelError] = []
    for name in args.names or list(MODEL_CARDS):
        status = model_status(name, model_dir)
        if status.state == "ok":
            print(f"ok  {name}  {status.path}")
        elif status.state == "missing":
            problems.append(
                ModelError(f"model {name!r} is not in the cache; run 'ergopose models fetch'", path=status.path)
            )
        else:
            problems.append(ModelError(corrupt_message(status), path=status.path))
    if not args.names:
        for path, card in _user_cards(model_dir):
            if isinstance(card, ErgoposeError):
                problems.append(ModelError(str(card)))
                continue
            state = _user_state(card)
            if state == "ok":
                print(f"ok  {card.name}  {card.file}")
            elif state == "unpinned":
                print(f"ok  {card.name}  {card.file}  (no sha256 in its card: not checked)")
            else:
                problems.append(
                    ModelError(
                        "ONNX model file is missing"
                        if state == "missing"
                        else "ONNX model file differs from the sha256 in its card",
                        path=card.file,
                    )
                )
    if problems:
        if len(problems) == 1:
            raise problems[0]
        raise ModelError(f"{problems[0]} (and {len(problems) - 1} more problem(s))")
    return 0
