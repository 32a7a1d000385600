"""Reading a scene folder (DESIGN §9 build-input layout) into a :class:`SceneFolder`.

Layout (``<stem>`` is a view's image stem, see :func:`view_stem`)::

    point_cloud.ply                            3DGS PLY (wins when both forms exist), or
    point_cloud/iteration_<N>/point_cloud.ply  the INRIA layout (largest N is taken)
    sparse/0/                                  COLMAP model (text or binary), or
    transforms.json                            nerfstudio cameras (sparse/0 wins)
    images/                                    optional RGB images
    masks/<stem>.npz                           per-view masks (:mod:`causalsplat.masks.files`)
    gt/gt_labels.npy                           optional (N,) int GT entity id per Gaussian
    objects.json, queries.json                 optional GT documents

Every problem with the folder raises :class:`SceneFolderFormatError` naming the path; errors
of the underlying readers are chained (``raise ... from``) and keep their message. Importing
this module imports neither torch nor plyfile.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import numpy as np

from causalsplat.build.mask_files import DEFAULT_BUDGET, MaskFiles
from causalsplat.errors import InputFormatError
from causalsplat.io import read_colmap_model, read_gaussian_ply, read_transforms_json
from causalsplat.io.errors import ColmapDistortionError
from causalsplat.io.types import Camera, GaussianScene
from causalsplat.masks.files import read_masks
from causalsplat.masks.types import MaskSet

_ITERATION = re.compile(r"iteration_(\d+)$")


class SceneFolderFormatError(InputFormatError):
    """A scene folder lacks a part or holds a malformed file; the message names the path."""


@dataclass(frozen=True, slots=True, eq=False)
class SceneFolder:
    """A scene folder as read (module docstring).

    Attributes:
        root: the folder (absolute).
        ply_path: the 3DGS PLY read.
        cameras_path: the ``sparse/0`` folder or the ``transforms.json`` file.
        gaussians: the N Gaussians of the PLY.
        cameras: the cameras that have a mask file (and were kept by ``max_views``), in
            camera order (COLMAP image id, or ``transforms.json`` frame order).
        masks: ``masks[i]`` belongs to ``cameras[i]``; ``masks[i].view`` is its stem and
            ``masks[i].masks`` is (M, height, width) bool at the camera's size. Read from
            the files when indexed, up to ``mask_budget`` bytes kept
            (:class:`~causalsplat.build.mask_files.MaskFiles`).
        gt_labels: (N,) int32 GT entity id per Gaussian (-1 none), or ``None``.
        objects_path, queries_path: ``objects.json`` / ``queries.json``, or ``None``.
        skipped_views: stems of the cameras without a mask file, in camera order.
        distorted: the COLMAP cameras whose lens distortion was dropped (read with
            ``allow_distortion=True``), described; empty otherwise.
    """

    root: Path
    ply_path: Path
    cameras_path: Path
    gaussians: GaussianScene
    cameras: tuple[Camera, ...]
    masks: Sequence[MaskSet]
    gt_labels: np.ndarray | None
    objects_path: Path | None
    queries_path: Path | None
    skipped_views: tuple[str, ...]
    distorted: tuple[str, ...] = ()

    def input_hashes(self) -> dict[str, str]:
        """SHA-256 hex digest of every input file, keyed by its POSIX path relative to root.

        Covers the PLY, the camera file(s) (``cameras`` and ``images`` of the COLMAP model as
        the reader picks them, or ``transforms.json``), the mask file of each kept view
        (``masks/<stem>.npz``) and ``gt/gt_labels.npy`` when present. Keys are sorted. The
        files are read again on each call (nothing is cached), so the result describes
        them as they are now.
        """
        files = [self.ply_path, *_camera_files(self.cameras_path)]
        files += [self.root / "masks" / f"{m.view}.npz" for m in self.masks]
        if self.gt_labels is not None:
            files.append(self.root / "gt" / "gt_labels.npy")
        out = {}
        for path in files:
            key = path.relative_to(self.root).as_posix()
            try:
                out[key] = _sha256(path)
            except OSError as exc:
                raise SceneFolderFormatError(f"{path}: cannot read for hashing: {exc}") from exc
        return dict(sorted(out.items()))


def view_stem(camera_name: str) -> str:
    """The image stem of a camera name: no directory, no extension.

    ``"images/frame_001.png"``, ``"./frame_001.png"`` and ``"frame_001"`` all give
    ``"frame_001"``; backslashes count as separators.
    """
    return PurePosixPath(camera_name.replace("\\", "/")).stem


def read_scene_folder(
    path: str | Path,
    *,
    max_views: int | None = None,
    allow_distortion: bool = False,
    mask_budget: int = DEFAULT_BUDGET,
) -> SceneFolder:
    """Read a scene folder (module docstring).

    Args:
        path: the folder.
        max_views: keep at most this many of the views that have masks, evenly spaced over
            the camera order, first and last included (deterministic; for quick builds).
            Only the kept views' mask files are read. ``None`` keeps all.
        allow_distortion: read COLMAP cameras with lens distortion as pinhole cameras
            (:attr:`SceneFolder.distorted` names them) instead of refusing them.
        mask_budget: bytes of mask arrays kept in memory; the other views' mask files are
            read again when a stage needs them. Every file is read and checked here.

    Raises :class:`SceneFolderFormatError` for a missing folder, PLY, cameras or ``masks/``,
    no camera with a mask file, a mask file matching no camera, two cameras with one stem,
    masks of the wrong size, malformed GT labels, any malformed file, or ``max_views < 1``.
    """
    if max_views is not None and max_views < 1:
        raise SceneFolderFormatError(f"max_views={max_views}: must be at least 1")
    root = Path(path).absolute()
    if not root.is_dir():
        what = "is not a folder" if root.exists() else "does not exist"
        raise SceneFolderFormatError(f"scene folder {root} {what}")
    ply_path = find_ply(root)
    try:
        gaussians = read_gaussian_ply(ply_path).scene
    except (InputFormatError, OSError) as exc:
        raise SceneFolderFormatError(f"scene folder {root}: bad PLY: {exc}") from exc
    cameras_path, all_cameras, distorted = _read_cameras(root, allow_distortion)
    with_masks, skipped = _match_masks(root, all_cameras)
    if max_views is not None:
        with_masks = [with_masks[i] for i in _spaced(len(with_masks), max_views)]
    masks = MaskFiles(
        len(with_masks), lambda i: _read_view_masks(root / "masks", with_masks[i]), mask_budget
    )
    objects, queries = root / "objects.json", root / "queries.json"
    return SceneFolder(
        root=root,
        ply_path=ply_path,
        cameras_path=cameras_path,
        gaussians=gaussians,
        cameras=tuple(with_masks),
        masks=masks,
        gt_labels=_read_gt_labels(root / "gt" / "gt_labels.npy", gaussians.n),
        objects_path=objects if objects.is_file() else None,
        queries_path=queries if queries.is_file() else None,
        skipped_views=skipped,
        distorted=distorted,
    )


def find_view_image(root: Path, stem: str, width: int, height: int) -> np.ndarray | None:
    """``images/<stem>.*`` of a scene folder as ``(H, W, 3)`` uint8 RGB, when there is one of
    the camera's size (``width`` x ``height``); else ``None`` (render the view instead)."""
    for path in sorted((root / "images").glob(f"{stem}.*")):
        from PIL import Image

        with Image.open(path) as im:
            rgb = np.asarray(im.convert("RGB"))
        if rgb.shape[:2] == (height, width):
            return rgb
    return None


def find_ply(root: Path) -> Path:
    """The folder's 3DGS PLY (top-level file first, else the largest INRIA iteration)."""
    top = root / "point_cloud.ply"
    if top.is_file():
        return top
    found: list[tuple[int, Path]] = []
    parent = root / "point_cloud"
    if parent.is_dir():
        for sub in parent.iterdir():
            m = _ITERATION.match(sub.name)
            if m and (sub / "point_cloud.ply").is_file():
                found.append((int(m.group(1)), sub / "point_cloud.ply"))
    if not found:
        raise SceneFolderFormatError(
            f"scene folder {root}: no 3DGS PLY; looked for {top} and "
            f"{parent}/iteration_<N>/point_cloud.ply"
        )
    return max(found)[1]


def read_cameras(root: Path, *, allow_distortion: bool = False) -> tuple[Path, tuple[Camera, ...]]:
    """The folder's camera source (``sparse/0`` or ``transforms.json``) and its cameras
    (COLMAP cameras with lens distortion refused unless ``allow_distortion``)."""
    source, cameras, _ = _read_cameras(root, allow_distortion)
    return source, cameras


def _read_cameras(
    root: Path, allow_distortion: bool
) -> tuple[Path, tuple[Camera, ...], tuple[str, ...]]:
    sparse, transforms = root / "sparse" / "0", root / "transforms.json"
    if not sparse.is_dir() and not transforms.is_file():
        raise SceneFolderFormatError(
            f"scene folder {root}: no cameras; looked for {sparse}/ and {transforms}"
        )
    source = sparse if sparse.is_dir() else transforms
    try:
        distorted: tuple[str, ...] = ()
        if source == sparse:
            model = read_colmap_model(sparse, allow_distortion=allow_distortion)
            cameras, distorted = model.cameras, model.distorted
        else:
            cameras = read_transforms_json(source)
    except ColmapDistortionError:
        raise  # its message names the file and the way out
    except (InputFormatError, OSError) as exc:
        raise SceneFolderFormatError(f"scene folder {root}: bad cameras: {exc}") from exc
    if not cameras:
        raise SceneFolderFormatError(f"{source}: holds no cameras")
    return source, cameras, distorted


def camera_sizes(root: str | Path) -> dict[str, tuple[int, int]]:
    """``(height, width)`` of every camera of a scene folder, by image stem (a camera's
    lens distortion does not change its size)."""
    _source, cameras = read_cameras(Path(root), allow_distortion=True)
    return {view_stem(c.name): (int(c.height), int(c.width)) for c in cameras}


def _camera_files(cameras_path: Path) -> list[Path]:
    if cameras_path.is_file():
        return [cameras_path]
    # the files read_colmap_model reads: .bin preferred over .txt
    pairs = [(cameras_path / f"{s}.bin", cameras_path / f"{s}.txt") for s in ("cameras", "images")]
    return [b if b.exists() else t for b, t in pairs if b.exists() or t.exists()]


def _match_masks(root: Path, cameras: tuple[Camera, ...]) -> tuple[list[Camera], tuple[str, ...]]:
    mask_dir = root / "masks"
    if not mask_dir.is_dir():
        raise SceneFolderFormatError(f"scene folder {root}: no masks folder {mask_dir}/")
    by_stem: dict[str, Camera] = {}
    for cam in cameras:
        stem = view_stem(cam.name)
        if stem in by_stem:
            raise SceneFolderFormatError(
                f"scene folder {root}: cameras {by_stem[stem].name!r} and {cam.name!r} share "
                f"the image stem {stem!r}, so masks/{stem}.npz is ambiguous"
            )
        by_stem[stem] = cam
    files = {p.stem for p in mask_dir.glob("*.npz")}
    other = sorted(
        p.name
        for p in mask_dir.iterdir()
        if p.suffix != ".npz" and p.stem in by_stem and p.stem not in files
    )
    if other:
        raise SceneFolderFormatError(
            f"{mask_dir}: {', '.join(other[:3])}{' ...' if len(other) > 3 else ''}: a build "
            f"reads each view's masks from masks/<image stem>.npz; convert SAM JSON, COCO RLE "
            f"or PNG masks with `causalsplat masks convert` (docs/formats.md)"
        )
    unknown = sorted(files - by_stem.keys())
    if unknown:
        raise SceneFolderFormatError(
            f"{mask_dir}: mask file(s) {', '.join(f'{s}.npz' for s in unknown)} match no "
            f"camera (the {len(by_stem)} cameras' stems are e.g. {sorted(by_stem)[:3]})"
        )
    if not files:
        raise SceneFolderFormatError(
            f"{mask_dir}: no camera has a mask file (expected masks/<image stem>.npz, e.g. "
            f"masks/{view_stem(cameras[0].name)}.npz)"
        )
    with_masks = [cam for stem, cam in by_stem.items() if stem in files]
    skipped = tuple(stem for stem in by_stem if stem not in files)
    return with_masks, skipped


def _spaced(n: int, k: int) -> list[int]:
    """``min(n, k)`` distinct indices into ``range(n)``, evenly spaced, ends included."""
    if k >= n:
        return list(range(n))
    if k == 1:
        return [0]
    return [(2 * i * (n - 1) + (k - 1)) // (2 * (k - 1)) for i in range(k)]


def _read_view_masks(mask_dir: Path, cam: Camera) -> MaskSet:
    stem = view_stem(cam.name)
    path = mask_dir / f"{stem}.npz"
    try:
        return read_masks(path, view=stem, image_size=(cam.width, cam.height))
    except (InputFormatError, OSError) as exc:
        raise SceneFolderFormatError(
            f"{path}: bad masks for camera {cam.name!r} ({cam.width}x{cam.height}): {exc}"
        ) from exc


def _read_gt_labels(path: Path, n: int) -> np.ndarray | None:
    if not path.exists():
        return None
    try:
        labels = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise SceneFolderFormatError(f"{path}: not a readable .npy array: {exc}") from exc
    if not isinstance(labels, np.ndarray):
        labels.close()
        raise SceneFolderFormatError(f"{path}: an .npz archive, not a single (N,) .npy array")
    if labels.dtype.kind not in "iu" or labels.shape != (n,):
        raise SceneFolderFormatError(
            f"{path}: dtype {labels.dtype}, shape {labels.shape}; expected ({n},) int "
            f"(one GT entity id per Gaussian of the PLY)"
        )
    if n and (int(labels.min()) < -1 or int(labels.max()) > np.iinfo(np.int32).max):
        raise SceneFolderFormatError(
            f"{path}: ids range {int(labels.min())}..{int(labels.max())}; expected -1 "
            f"(none) or a non-negative int32"
        )
    return labels.astype(np.int32)


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()
