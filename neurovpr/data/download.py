"""Download helpers (pooch, with checksums). Nothing here runs in the tests.

:func:`fetch_vprsnn_lists` fetches the image-name lists and the St Lucia ground truth
that define the published traverses (QVPR/VPRSNN, MIT licence) from a pinned commit,
each file checked against its SHA-256. :func:`fetch` downloads any other file and
refuses to do so without a checksum, so a changed or truncated download is never used.

The image datasets themselves are large and each has its own terms; :data:`SOURCES`
says where each is published. neurovpr ships none of them.
"""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType

from neurovpr.errors import ValidationError

__all__ = ["VPRSNN_COMMIT", "VPRSNN_FILES", "SOURCES", "fetch_vprsnn_lists", "fetch"]

#: Commit of QVPR/VPRSNN the lists are taken from.
VPRSNN_COMMIT = "d38f30c2fa8eff5f8fa4a20f48644fe7b3e84204"
_VPRSNN_BASE = f"https://raw.githubusercontent.com/QVPR/VPRSNN/{VPRSNN_COMMIT}/"

#: SHA-256 of each VPRSNN image-name list (folder ``dataset_imagenames/``).
_LIST_SHA256 = {
    "ORC_Dusk_timestamps.csv": "2dd5bec3a21c24c10d9f50269a4c002592813c05121abda5583c1314b49a92c0",
    "ORC_Rain_timestamps.csv": "3e14761fcdf94c70149c96692450c111b074366e1214c2adf998259c7782b82f",
    "ORC_Sun_timestamps.csv": "676a7783b668866f35a298d5244a866220022506ec64ceb11c3ef3388cdd9bfe",
    "ORC_imageNames_Dusk.txt": "b819a0033bbca5bc5a2a20ddd587ac3ab33dcffcc2246bcd8f1c3ae480c8cde9",
    "ORC_imageNames_Rain.txt": "4f71ceb4acac12abbbfb48ee21e1444ab4ba86ab57f0b0e60d7e02c5418d9051",
    "ORC_imageNames_Sun.txt": "2c63491d3fbc5cd2545baaf2d05a1e1e4e6b2ccaf61a57dc616a197c0d85cad6",
    "SFU-Mountain_imageNames_dry.txt": "fce11c4371433e9e5efb1b69aeba3b3becdc68c8d4f58746eb6f28681aaab2f7",
    "SFU-Mountain_imageNames_dusk.txt": "323fbab05af8efc0a5b2ee799a609bd7dc339919991e0aba0cc68ebcde927ea3",
    "St-Lucia_imageNames_180809_1545.txt": "d494e5ab164bd3e440a0ca1eadb17217800bc0cf064d4dc9a9ff3ce6c0354790",
    "St-Lucia_imageNames_190809_0845.txt": "0e38535c8e47d600dc4126f02e2c65a7dcfd05b74f951e588919720377819e07",
    "Synthia-NightToFall_imageNames_query.txt": "90dadceca3274228d183bbff080d3459d740e81372d54e770b355b6461991eff",
    "Synthia-NightToFall_imageNames_ref.txt": "db01db86ad5229f82d47a023d06e56bfe4ca64cbc1969acfbac38ead0422340d",
    "nordland_imageNames.txt": "6b1dcf6a8ccf2860f5b473dce84941fff87735bcb94face0af66d14fba49ff73",
    "nordland_imageNames_fall.txt": "d2c691842468393562ca92260109750416e728fdf78aba94ec283d90023f0bfa",
    "nordland_imageNames_spring.txt": "8a7a7513d81d4895a50f74bf8da005fa643f92f73f775a4e1f19b5ac29690bf2",
    "nordland_imageNames_summer.txt": "cdbc1f1672c11707aea4fc79dcca00ad94499697a913cb4caf57f009c6cf640d",
    "nordland_imageNames_winter.txt": "6ddb3b60931077f5495d69e1ad396791e13c5eefeca7579e4bd2158abdd5f7ad",
}

#: Relative path -> SHA-256 of every file :func:`fetch_vprsnn_lists` downloads.
VPRSNN_FILES: MappingProxyType[str, str] = MappingProxyType(
    {
        **{f"dataset_imagenames/{name}": sha for name, sha in _LIST_SHA256.items()},
        "dataset_gt_files/St_Lucia_gt_boolean_matrix.npy": "095ba86625a72df80b417e6dba3a51f62007bd62c41b00715ed30db7e4c8b017",
    }
)

#: Where each published dataset's images are distributed (read their terms before use).
SOURCES: MappingProxyType[str, str] = MappingProxyType(
    {
        "nordland": "https://huggingface.co/datasets/Somayeh-h/Nordland (the variant the VPRSNN lists refer to)",
        "orc": "https://robotcar-dataset.robots.ox.ac.uk (Oxford RobotCar; VPRSNN renames frames, see its ORC_*_timestamps.csv)",
        "sfu-mountain": "SFU Mountain dataset (Bruce, Wawerla & Vaughan, 2015): part_a/part_b stereo_right frames, dry and dusk",
        "synthia": "https://synthia-dataset.net (SYNTHIA, night-to-fall sequences as arranged by VPRSNN)",
        "st-lucia": "UQ St Lucia multiple-times-of-day dataset (Glover et al., ICRA 2010), traverses 190809_0845 and 180809_1545",
    }
)


def _pooch():
    try:
        import pooch
    except ImportError as exc:  # pragma: no cover - pooch is a declared dependency
        raise ValidationError("downloads need the 'pooch' package, which is not installed.") from exc
    return pooch


def fetch_vprsnn_lists(dest: str | Path | None = None, *, progress: bool = True) -> Path:
    """Download the VPRSNN lists into ``dest`` (default: neurovpr's cache); returns ``dest``.

    ``dest`` then holds ``dataset_imagenames/`` and ``dataset_gt_files/`` and can be
    passed as ``lists=`` to :func:`neurovpr.data.published.load_published`. Files
    already present with the right checksum are not downloaded again.
    """
    pooch = _pooch()
    if dest is None:
        from neurovpr.data.published import default_lists_folder

        dest = default_lists_folder()
    dest = Path(dest)
    registry = pooch.create(path=dest, base_url=_VPRSNN_BASE, registry={k: f"sha256:{v}" for k, v in VPRSNN_FILES.items()})
    for name in VPRSNN_FILES:
        registry.fetch(name, progressbar=progress)
    return dest


def fetch(url: str, known_hash: str, dest: str | Path, *, fname: str | None = None, progress: bool = True) -> Path:
    """Download ``url`` into folder ``dest`` and check it against ``known_hash``.

    ``known_hash`` is ``"sha256:<hex>"`` (or ``md5:``/``sha1:``); ``None`` or an empty
    string is refused, so every download is verified. Returns the file's path.
    """
    if not known_hash or ":" not in known_hash:
        raise ValidationError(f"download of {url} needs a checksum such as 'sha256:<hex>', got {known_hash!r}.")
    pooch = _pooch()
    path = pooch.retrieve(url=url, known_hash=known_hash, path=Path(dest), fname=fname, progressbar=progress)
    return Path(path)
