"""Fine-tuning from shipped weights and quantising them: a network rebuilt from its ONNX export computes what the
export computes (also with the stride-32 branch added, which starts silent), an export of another network is
refused by name, a fine-tuning run records the weights it started from, and the int8 model keeps its float ends,
runs through the shipped detector's path and finds what the float model finds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")

from agentic_core.perception.detectors import OnnxDetector
from agentic_core.perception.detectors.ours import load_ours
from evaluation.detector import quantise as quantising
from evaluation.detector.network import PersonNet, YoloV8Export
from evaluation.detector.train import TrainConfig, export_onnx, main, render_frames, train, write_recipe
from evaluation.detector.warm_start import net_from_onnx

SMALL = TrainConfig(frames=3, width_px=320, height_px=240, crop_px=96, batch=2, crops_per_frame=2, epochs=1)


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Any]]:
    """A few steps of training, exported with its recipe; and the frames it saw."""
    folder = tmp_path_factory.mktemp("float")
    frames = render_frames(SMALL)
    net, stats = train(frames, SMALL, log=lambda _: None, max_steps=3)
    digest = export_onnx(net, folder / "person.onnx", width=320, height=240)
    write_recipe(folder / "person.json", SMALL, stats, digest)
    return folder, frames


def _onnx_output(path: Path, x: np.ndarray) -> np.ndarray:
    ort: Any = pytest.importorskip("onnxruntime")
    return np.asarray(ort.InferenceSession(str(path)).run(None, {"images": x})[0])


@pytest.mark.parametrize("context32", [False, True])
def test_a_rebuilt_network_computes_what_its_export_computes(exported: tuple[Path, list[Any]], context32: bool) -> None:
    torch: Any = pytest.importorskip("torch")
    folder, _ = exported
    x = np.random.default_rng(5).random((1, 3, 240, 320), dtype=np.float32)
    net = net_from_onnx(folder / "person.onnx", SMALL.net_width, context32=context32).eval()
    with torch.no_grad():
        rebuilt = YoloV8Export(net)(torch.from_numpy(x)).numpy()
    expected = _onnx_output(folder / "person.onnx", x)
    assert rebuilt.shape == expected.shape
    assert np.abs(rebuilt - expected).max() <= 1e-3 * max(1.0, float(np.abs(expected).max()))
    assert np.abs(expected[0, 4]).max() > 0  # the scores are not all zero: the comparison compared something


def test_an_export_of_another_network_is_refused_by_name(tmp_path: Path) -> None:
    other = PersonNet(16).eval()
    export_onnx(other, tmp_path / "person.onnx", width=320, height=240)
    with pytest.raises(ValueError, match=r"person\.onnx: stem\.1 has shape \(16, 16, 3, 3\), not \(24, 16, 3, 3\)"):
        net_from_onnx(tmp_path / "person.onnx", 24)


def test_fine_tuning_records_the_weights_it_started_from(exported: tuple[Path, list[Any]], tmp_path: Path) -> None:
    folder, _ = exported
    args = ["--out", str(tmp_path), "--frames", "2", "--epochs", "1", "--batch", "2", "--crops-per-frame", "1",
            "--init", str(folder / "person.onnx"), "--extra-seed", "4", "--extra-frames", "1",
            "--extra-altitudes", "12.5", "--context32", "--max-minutes", "0.05"]  # fmt: skip
    assert main(args) == 0
    recipe = json.loads((tmp_path / "person.json").read_text())
    parent = json.loads((folder / "person.json").read_text())
    assert recipe["config"]["init_sha256"] == parent["sha256"] == recipe["parent"]["sha256"]
    assert recipe["config"]["context32"] is True and recipe["config"]["extra_altitudes_m"] == [12.5]
    assert recipe["sha256"] != parent["sha256"]
    OnnxDetector(tmp_path / "person.onnx", score_threshold=0.0).detect_array(np.zeros((240, 320, 3), np.uint8))


def test_extra_frames_without_their_seed_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stopped:
        main(["--out", str(tmp_path), "--extra-frames", "5"])
    assert stopped.value.code == 2 and "--extra-frames needs --extra-seed" in capsys.readouterr().err


def test_the_int8_model_keeps_its_float_ends_and_finds_what_the_float_one_finds(
    exported: tuple[Path, list[Any]], tmp_path: Path
) -> None:
    folder, frames = exported
    assert quantising.main(["--src", str(folder), "--out", str(tmp_path), "--frames", "2"]) == 0
    recipe = json.loads((tmp_path / "person.json").read_text())
    float_recipe = json.loads((folder / "person.json").read_text())
    assert recipe["quantisation"]["float_sha256"] == float_recipe["sha256"] != recipe["sha256"]
    onnx: Any = pytest.importorskip("onnx")
    graph = onnx.load(str(tmp_path / "person.onnx")).graph
    quantised = {n.name for n in graph.node if n.op_type == "QuantizeLinear"}
    assert any(name.startswith("/net/down16") for name in quantised)
    float_convs = {n.name for n in graph.node if n.op_type == "Conv"}
    assert set(quantising.FLOAT_NODES) & {n.name for n in graph.node} >= {"/net/head/head.1/Conv"}
    assert "/net/head/head.1/Conv" in float_convs
    assert not any(n.op_type == "DequantizeLinear" and n.input[0] == "images" for n in graph.node)
    load_ours(tmp_path).detect_array(frames[0].image)  # the shipped path: the SHA-256 checked against the recipe
    x = np.ascontiguousarray(frames[0].image.transpose(2, 0, 1)[None], dtype=np.float32) / 255.0
    f32, i8 = _onnx_output(folder / "person.onnx", x)[0], _onnx_output(tmp_path / "person.onnx", x)[0]
    both = (f32[4] > 0) & (i8[4] > 0)  # cells that are a peak in both
    # most of the float model's peaks are the int8 one's too (0.88-0.92 over repeated runs), and enough of them to
    # compare. The old 'a twentieth of all cells' (240 of 4,800) sat a dozen cells under the 249-258 that training
    # three steps gives, which varies from run to run (oneDNN's sums are not bit-reproducible): the likely cause
    # of the one failure seen
    assert both.sum() >= 100 and both.sum() >= 0.8 * (f32[4] > 0).sum()
    assert np.corrcoef(f32[4][both], i8[4][both])[0, 1] > 0.9
    assert np.abs(f32[:2] - i8[:2]).max() < 0.5  # centres within half a pixel
    assert np.median(np.abs(np.log(i8[2:4] / f32[2:4]))) < 0.05  # sizes within 5 %


def test_an_int8_export_is_rebuilt_with_its_weights_dequantised(
    exported: tuple[Path, list[Any]], tmp_path: Path
) -> None:
    """The shipped weights are int8: fine-tuning from them rebuilds each convolution from its DequantizeLinear
    (q − zero point) × scale, within half a quantisation step of the float weights it was quantised from."""
    torch: Any = pytest.importorskip("torch")
    folder, _ = exported
    assert quantising.main(["--src", str(folder), "--out", str(tmp_path), "--frames", "2"]) == 0
    float_net = net_from_onnx(folder / "person.onnx", SMALL.net_width)
    int8_net = net_from_onnx(tmp_path / "person.onnx", SMALL.net_width)
    compared = 0
    for (name, a), (_, b) in zip(float_net.state_dict().items(), int8_net.state_dict().items(), strict=True):
        if not name.endswith("weight") or a.dim() != 4:
            continue
        step = torch.abs(a).amax(dim=(1, 2, 3), keepdim=True) / 127.0  # symmetric int8, per output channel
        assert bool((torch.abs(a - b) <= 0.51 * step + 1e-7).all()), name
        compared += 1
    assert compared >= 10
    assert any(not torch.equal(a, b) for a, b in zip(float_net.parameters(), int8_net.parameters(), strict=True))
