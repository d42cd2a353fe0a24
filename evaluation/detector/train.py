"""Train our person detector on rendered frames and export it to ONNX in the YOLOv8 layout, with its recipe.

``python -m evaluation.detector.train --out DIR`` renders ``--frames`` labelled frames from ``--seed``
(:func:`flight.sim.render.dataset.labelled_frames`), trains :class:`PersonNet` on square crops of them (torch on
the CPU, the ``train`` extra) for ``--epochs`` or until ``--max-minutes``, whichever comes first, and writes
``person.onnx`` and ``person.json`` (the recipe: data seed, counts, sizes, epochs done, the file's SHA-256).
Calibration is added to the recipe afterwards (``python -m evaluation.detector.calibrate``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.extras import require

from .crops import sample_crops, targets, turn

WEIGHTS_NAME = "person.onnx"
RECIPE_NAME = "person.json"


class Labelled(Protocol):
    """What training reads of a rendered frame (:class:`flight.sim.render.dataset.LabelledFrame`)."""

    @property
    def image(self) -> NDArray[np.uint8]: ...
    @property
    def boxes(self) -> NDArray[np.float32]: ...
    @property
    def poses(self) -> tuple[str, ...]: ...
    @property
    def altitude_m(self) -> float: ...
    @property
    def visible(self) -> NDArray[np.float32]: ...


@dataclass(frozen=True)
class TrainConfig:
    """Everything that decides the weights; written into the recipe."""

    data_seed: int = 1
    frames: int = 1200
    width_px: int = 640
    height_px: int = 480
    altitudes_m: tuple[float, ...] = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0)
    crop_px: int = 224
    crops_per_frame: int = 4
    batch: int = 16
    epochs: int = 12
    max_minutes: float = 60.0
    max_cpu_minutes: float = 40.0
    net_width: int = 24
    context32: bool = False
    learning_rate: float = 2e-3
    torch_seed: int = 0
    threads: int = 2
    extra_seed: int | None = None
    extra_frames: int = 0
    extra_altitudes_m: tuple[float, ...] = ()
    init_sha256: str | None = None
    """The SHA-256 of the ONNX weights training started from (:mod:`.warm_start`), None for a fresh network."""
    neighbour_boxes: bool = False
    """Teach the box at the two cells next to each centre too (:func:`.crops.targets`)."""
    steps: int | None = None
    """Train exactly this many steps, the learning rate's schedule following them alone and no time budget
    applied: the same frames, seed, threads and steps give the same weights. None: ``epochs``, cut short by
    ``max_minutes`` or ``max_cpu_minutes``, whose schedule follows the clock (how long depends on the machine)."""


@dataclass
class TrainStats:
    """What training did: epochs and steps done, the loss by epoch, the wall time."""

    epochs_done: int = 0
    steps: int = 0
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    loss_by_epoch: list[float] = field(default_factory=list)
    stopped_by: str = ""
    """What ended training: ``steps`` (the step budget or the epochs done), ``wall clock`` or ``CPU time``."""


RENDER_WORKERS = min(2, os.cpu_count() or 1)
"""Processes the training command renders its frames in (:func:`render_frames`)."""
RENDER_CHUNK = 64
"""Frames a worker renders at a time (a multiple of the dataset's views per scene); a series this long or shorter
is rendered in this process."""


def _render_part(seed: int, start: int, count: int, altitudes_m: tuple[float, ...], size: tuple[int, int]) -> list[Any]:
    from flight.sim.render.dataset import labelled_frames

    width, height = size
    return list(labelled_frames(seed, count, altitudes_m=altitudes_m, width=width, height=height, start=start))


def render_frames(
    config: TrainConfig, *, seed: int | None = None, count: int | None = None, workers: int = 1
) -> list[Labelled]:
    """The labelled frames of ``seed`` (the config's data seed by default): the same whatever ``workers``. With
    ``workers`` above 1 a long series is rendered in parts of :data:`RENDER_CHUNK` frames over that many spawned
    processes, which import the caller's main module again: call it so only from a guarded ``__main__`` (as the
    training command does, where rendering is most of a short run's set-up)."""
    seed = config.data_seed if seed is None else seed
    count = config.frames if count is None else count
    size = (config.width_px, config.height_px)
    if workers <= 1 or count <= RENDER_CHUNK:
        return _render_part(seed, 0, count, config.altitudes_m, size)
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    starts = range(0, count, RENDER_CHUNK)
    counts = [min(RENDER_CHUNK, count - start) for start in starts]
    context = multiprocessing.get_context("spawn")  # not fork: torch's thread pools may already be running here
    with ProcessPoolExecutor(workers, mp_context=context) as pool:
        parts = pool.map(_render_part, [seed] * len(counts), starts, counts, [config.altitudes_m] * len(counts),
                         [size] * len(counts))  # fmt: skip
        return [frame for part in parts for frame in part]


@dataclass(frozen=True)
class CachedFrame:
    """A labelled frame read back from a cache file."""

    image: NDArray[np.uint8]
    boxes: NDArray[np.float32]
    poses: tuple[str, ...]
    altitude_m: float
    visible: NDArray[np.float32]


def save_frames(path: Path, frames: Sequence[Labelled]) -> None:
    """Keep rendered frames in one ``.npz``, so a second training run need not render them again."""
    counts = np.array([len(f.boxes) for f in frames], np.int64)
    boxes = np.concatenate([f.boxes for f in frames] or [np.zeros((0, 4), np.float32)])
    poses = np.array([p for f in frames for p in f.poses], dtype="U8")
    altitudes = np.array([f.altitude_m for f in frames])
    images = np.stack([f.image for f in frames])
    visible = np.concatenate([f.visible for f in frames] or [np.zeros(0, np.float32)])
    np.savez(path, images=images, boxes=boxes, counts=counts, poses=poses, altitudes=altitudes, visible=visible)


def load_frames(path: Path) -> list[Labelled]:
    """The frames :func:`save_frames` kept (each array read once: an ``.npz`` member is read again on every access);
    :class:`ValueError` for a cache written before labels had a visible share (render it again)."""
    data = np.load(path)
    if "visible" not in data.files:
        raise ValueError(f"{path}: a frame cache without visible shares (from an older version); delete it")
    images, boxes, visible, altitudes = data["images"], data["boxes"], data["visible"], data["altitudes"]
    ends = np.cumsum(data["counts"])
    starts = ends - data["counts"]
    poses = [str(p) for p in data["poses"]]
    return [
        CachedFrame(images[k], boxes[a:b], tuple(poses[a:b]), float(altitudes[k]), visible[a:b])
        for k, (a, b) in enumerate(zip(starts.tolist(), ends.tolist(), strict=True))
    ]


def focal_loss(torch: Any, logits: Any, heat: Any, weight: Any) -> Any:
    """The centre-point focal loss: positives where the target is 1, negatives down-weighted near a centre and
    left out where ``weight`` is 0 (around ignored persons)."""
    p = torch.sigmoid(logits).clamp(1e-4, 1 - 1e-4)
    pos = heat.eq(1.0).float()
    pos_loss = -torch.log(p) * (1 - p) ** 2 * pos
    neg_loss = -torch.log(1 - p) * p**2 * (1 - heat) ** 4 * (1 - pos) * weight
    return (pos_loss.sum() + neg_loss.sum()) / pos.sum().clamp(min=1.0)


def giou_loss(torch: Any, pred: Any, true: Any) -> Any:
    """Mean of 1 − generalised IoU between corner boxes (K×4 each): scale-free, so a 5-pixel person's box counts
    as much as a 60-pixel one's."""
    ix = (torch.minimum(pred[:, 2], true[:, 2]) - torch.maximum(pred[:, 0], true[:, 0])).clamp(min=0)
    iy = (torch.minimum(pred[:, 3], true[:, 3]) - torch.maximum(pred[:, 1], true[:, 1])).clamp(min=0)
    inter = ix * iy
    area_p = (pred[:, 2] - pred[:, 0]) * (pred[:, 3] - pred[:, 1])
    area_t = (true[:, 2] - true[:, 0]) * (true[:, 3] - true[:, 1])
    union = area_p + area_t - inter
    hull = (torch.maximum(pred[:, 2], true[:, 2]) - torch.minimum(pred[:, 0], true[:, 0])) * (
        torch.maximum(pred[:, 3], true[:, 3]) - torch.minimum(pred[:, 1], true[:, 1])
    )
    giou = inter / union.clamp(min=1e-6) - (hull - union) / hull.clamp(min=1e-6)
    return (1.0 - giou).mean()


def detection_loss(torch: Any, raw: Any, batch: tuple[Any, ...]) -> Any:
    """Focal loss on the score, and at each person's centre cell L1 on offset and log size plus GIoU on the box."""
    from .network import decode_grid

    heat, weight, reg, box, mask = (torch.from_numpy(a) for a in batch[1:])
    loss = focal_loss(torch, raw[:, 0], heat, weight)
    cells = mask.bool()
    if cells.any():
        offsets = torch.sigmoid(raw[:, 1:3]) * 2.0 - 0.5
        pred = torch.cat([offsets, raw[:, 3:5]], 1).permute(0, 2, 3, 1)[cells]
        loss = loss + torch.nn.functional.l1_loss(pred, reg.permute(0, 2, 3, 1)[cells])
        _, cx, cy, w, h = decode_grid(raw)
        corners = torch.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], 1).permute(0, 2, 3, 1)[cells]
        loss = loss + 2.0 * giou_loss(torch, corners, box.permute(0, 2, 3, 1)[cells])
    return loss


def _batches(frames: Sequence[Labelled], config: TrainConfig, rng: np.random.Generator) -> Iterable[tuple[Any, ...]]:
    """One epoch's batches: crops of every frame, turned, shuffled; images N×3×S×S in 0–1 and the targets."""
    from .network import STRIDE

    samples: list[tuple[NDArray[np.uint8], NDArray[np.float32], NDArray[np.float32]]] = []
    for frame in frames:
        for crop, boxes, visible in sample_crops(
            frame.image, frame.boxes, frame.visible, rng, size=config.crop_px, count=config.crops_per_frame
        ):
            samples.append((*turn(crop, boxes, int(rng.integers(8))), visible))
    order = rng.permutation(len(samples))
    for start in range(0, len(order) - config.batch + 1, config.batch):
        chosen = [samples[i] for i in order[start : start + config.batch]]
        images = np.stack([c for c, _, _ in chosen]).astype(np.float32).transpose(0, 3, 1, 2) / 255.0
        gain = rng.uniform(0.85, 1.15, (len(chosen), 1, 1, 1)).astype(np.float32)
        images = np.clip(images * gain, 0.0, 1.0)
        made = [
            targets(b, v, size=config.crop_px, stride=STRIDE, neighbour_boxes=config.neighbour_boxes)
            for _, b, v in chosen
        ]
        names = ("heat", "weight", "reg", "box", "mask")
        yield (images, *(np.stack([getattr(t, name) for t in made]) for name in names))


def learning_rate(peak: float, progress: float) -> float:
    """A short warm-up, then a cosine down to 1 % of ``peak``; ``progress`` (0–1) is the larger of the steps' and
    the time budgets' shares used, so a run cut short by ``max_minutes`` or ``max_cpu_minutes`` still ends on a low
    rate.

    >>> [round(learning_rate(1.0, p), 3) for p in (0.0, 0.05, 0.5, 1.0)]
    [0.1, 1.0, 0.546, 0.01]
    """
    if progress < 0.05:
        return peak * (0.1 + 0.9 * progress / 0.05)
    t = min(1.0, (progress - 0.05) / 0.95)
    return peak * (0.01 + 0.99 * 0.5 * (1.0 + math.cos(math.pi * t)))


class _Budget:
    """Training's two time budgets: wall-clock seconds, and CPU seconds of this process (all its threads), the
    one that says what training costs on a machine shared with others."""

    def __init__(self, wall_s: float, cpu_s: float) -> None:
        self._wall0, self._cpu0 = time.monotonic(), time.process_time()
        self._wall_s, self._cpu_s = max(wall_s, 1e-9), max(cpu_s, 1e-9)

    def wall(self) -> float:
        return time.monotonic() - self._wall0

    def cpu(self) -> float:
        return time.process_time() - self._cpu0

    def used(self) -> float:
        """The larger share used of the two budgets (1 or more: spent)."""
        return max(self.wall() / self._wall_s, self.cpu() / self._cpu_s)

    def spent_on(self) -> str:
        """Which budget ran out (``steps`` when neither did)."""
        if self.wall() >= self._wall_s:
            return "wall clock"
        return "CPU time" if self.cpu() >= self._cpu_s else "steps"


def train(
    frames: Sequence[Labelled],
    config: TrainConfig,
    *,
    log: Callable[[str], None] = print,
    max_steps: int | None = None,
    init: Any | None = None,
) -> tuple[Any, TrainStats]:
    """Train a :class:`PersonNet` on ``frames`` (``init``, one rebuilt by :func:`.warm_start.net_from_onnx`, is
    fine-tuned with its folded normalisations frozen; a fresh one otherwise); returns it (in eval mode) and what
    was done."""
    torch: Any = require("torch", "train")
    from .network import PersonNet
    from .warm_start import freeze_norms

    torch.manual_seed(config.torch_seed)
    torch.set_num_threads(config.threads)
    rng = np.random.default_rng(config.torch_seed)
    net = PersonNet(config.net_width, context32=config.context32) if init is None else init
    net = net.to(memory_format=torch.channels_last)  # oneDNN's own layout: about 1.2-1.4x faster steps on the CPU
    per_epoch = max(1, len(frames) * config.crops_per_frame // config.batch)
    total = per_epoch * config.epochs if config.steps is None else config.steps
    total = total if max_steps is None else min(max_steps, total)
    optimiser = torch.optim.AdamW(net.parameters(), lr=config.learning_rate, weight_decay=1e-4)
    stats = TrainStats()
    timed = config.steps is None
    budget = _Budget(
        config.max_minutes * 60.0 if timed else math.inf, config.max_cpu_minutes * 60.0 if timed else math.inf
    )
    net.train()
    if init is not None:
        freeze_norms(net)
    while stats.steps < total and budget.used() < 1.0:
        losses: list[float] = []
        for batch in _batches(frames, config, rng):
            raw = net(torch.from_numpy(batch[0]).contiguous(memory_format=torch.channels_last))
            loss = detection_loss(torch, raw, batch)
            progress = max(stats.steps / total, budget.used())
            for group in optimiser.param_groups:
                group["lr"] = learning_rate(config.learning_rate, progress)
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            losses.append(float(loss.detach()))
            stats.steps += 1
            if stats.steps >= total or budget.used() >= 1.0:
                break
        stats.epochs_done += 1
        stats.loss_by_epoch.append(round(float(np.mean(losses)) if losses else math.nan, 4))
        log(f"epoch {stats.epochs_done}: {stats.steps}/{total} steps, loss {stats.loss_by_epoch[-1]}, "
            f"{budget.wall():.0f} s, {budget.cpu():.0f} CPU s")  # fmt: skip
    stats.seconds, stats.cpu_seconds = round(budget.wall(), 1), round(budget.cpu(), 1)
    stats.stopped_by = "steps" if stats.steps >= total else budget.spent_on()
    net.eval()
    return net, stats


def export_onnx(net: Any, path: Path, *, width: int = 640, height: int = 480) -> str:
    """Write ``net`` as an ONNX model in the YOLOv8 layout for a ``width``×``height`` input; returns its SHA-256."""
    torch: Any = require("torch", "train")
    from .network import YoloV8Export

    model = YoloV8Export(net).eval()
    example = torch.zeros(1, 3, height, width)
    path.parent.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(
            model, (example,), str(path), input_names=["images"], output_names=["output0"], opset_version=17,
            dynamo=False,
        )  # fmt: skip
    onnx: Any = require("onnx", "train")
    saved = onnx.load(str(path))
    for key, value in (("names", "{0: 'person'}"), ("stride", "4"), ("producer", "agentic-uavs evaluation.detector")):
        entry = saved.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.save(saved, str(path))
    return sha256_of(path)


def sha256_of(path: Path) -> str:
    """The file's SHA-256, hex."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_recipe(path: Path, config: TrainConfig, stats: TrainStats, sha256: str, **extra: Any) -> None:
    """The recipe beside the weights: how they were made, and the SHA-256 that ties the two."""
    recipe = {
        "weights": WEIGHTS_NAME,
        "sha256": sha256,
        "licence": "Apache-2.0 (the project's); trained here on frames rendered by flight.sim.render",
        "config": asdict(config),
        "training": asdict(stats),
        **extra,
    }
    path.write_text(json.dumps(recipe, indent=2) + "\n")


def _cached(path: Path | None, render: Callable[[], list[Labelled]]) -> list[Labelled]:
    """Frames read from ``path`` when it exists, else rendered (and kept there when a path is given)."""
    if path is not None and path.is_file():
        return load_frames(path)
    frames = render()
    if path is not None:
        save_frames(path, frames)
    return frames


def main(argv: Sequence[str] | None = None) -> int:
    """The training command line."""
    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.train", description=__doc__)
    parser.add_argument("--out", type=Path, required=True, help="folder for person.onnx and person.json")
    defaults = TrainConfig()
    for name in ("data_seed", "frames", "epochs", "crops_per_frame", "batch", "net_width", "threads", "extra_frames"):
        parser.add_argument(f"--{name.replace('_', '-')}", type=int, default=getattr(defaults, name))
    parser.add_argument(
        "--steps", type=int, help="train exactly this many steps, no time budget: the same steps, the same weights"
    )
    parser.add_argument("--max-minutes", type=float, default=defaults.max_minutes, help="wall-clock budget")
    parser.add_argument(
        "--max-cpu-minutes", type=float, default=defaults.max_cpu_minutes, help="CPU budget, all threads together"
    )
    parser.add_argument("--learning-rate", type=float, default=defaults.learning_rate)
    parser.add_argument("--context32", action="store_true", help="add the stride-32 context branch")
    parser.add_argument(
        "--neighbour-boxes", action="store_true", help="teach the box at the two cells next to each centre too"
    )
    parser.add_argument("--cache", type=Path, help="an .npz of the rendered frames: read if it exists, else written")
    parser.add_argument("--init", type=Path, help="an ONNX export of this network to fine-tune (its recipe beside it)")
    parser.add_argument("--extra-seed", type=int, help="a second data seed, rendered at --extra-altitudes")
    parser.add_argument("--extra-altitudes", type=float, nargs="+", default=[], help="metres, for --extra-frames")
    parser.add_argument("--extra-cache", type=Path, help="as --cache, for the extra frames")
    args = parser.parse_args(argv)
    if args.extra_frames and (args.extra_seed is None or not args.extra_altitudes):
        parser.error("--extra-frames needs --extra-seed and --extra-altitudes")
    if args.steps is not None and args.steps < 1:
        parser.error("--steps must be at least 1")
    config = TrainConfig(
        **{k: getattr(args, k) for k in ("data_seed", "frames", "epochs", "crops_per_frame", "batch", "net_width")},
        threads=args.threads,
        max_minutes=args.max_minutes,
        max_cpu_minutes=args.max_cpu_minutes,
        learning_rate=args.learning_rate,
        context32=args.context32,
        extra_seed=args.extra_seed,
        extra_frames=args.extra_frames,
        extra_altitudes_m=tuple(args.extra_altitudes),
        init_sha256=None if args.init is None else sha256_of(args.init),
        neighbour_boxes=args.neighbour_boxes,
        steps=args.steps,
    )
    started = time.monotonic()
    frames = _cached(args.cache, lambda: render_frames(config, workers=RENDER_WORKERS))
    if config.extra_frames:
        extra = TrainConfig(altitudes_m=config.extra_altitudes_m, width_px=config.width_px, height_px=config.height_px)
        frames += _cached(
            args.extra_cache,
            lambda: render_frames(extra, seed=args.extra_seed, count=args.extra_frames, workers=RENDER_WORKERS),
        )
    print(f"rendered {len(frames)} frames in {time.monotonic() - started:.0f} s", flush=True)
    init, parent = None, {}
    if args.init is not None:
        from .warm_start import net_from_onnx

        init = net_from_onnx(args.init, config.net_width, context32=config.context32)
        beside = args.init.parent / RECIPE_NAME
        if beside.is_file():
            old = json.loads(beside.read_text())
            parent = {"parent": {k: old.get(k) for k in ("sha256", "config", "training", "parent")}}
    net, stats = train(frames, config, log=lambda line: print(line, flush=True), init=init)
    weights = args.out / WEIGHTS_NAME
    digest = export_onnx(net, weights, width=config.width_px, height=config.height_px)
    write_recipe(args.out / RECIPE_NAME, config, stats, digest, **parent)
    print(f"wrote {weights} ({digest})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
