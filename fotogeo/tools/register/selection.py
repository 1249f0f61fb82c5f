"""What ``register`` and ``match`` match: the bands fused of each image (``reference_bands`` / ``target_bands``,
1-based as ``gdal_translate -b``: :func:`band_numbers`, :func:`select_bands`) and the descriptor matches kept by the
options' ratio test (:func:`match_keypoints`) — shared by the matching tool (:mod:`.match`) and the band re-match
(:mod:`.bands`)."""
from __future__ import annotations

import numpy as np

from ...errors import InputError
from ...features.match import match_descriptors
from ...options import REGISTER


def band_numbers(value, option: str) -> tuple[int, ...] | None:
    """The band numbers of a ``*_bands`` option: ``"1,2,3"`` (or ``"1 2 3"``, an int, a sequence of
    ints) → ``(1, 2, 3)``; None or empty → None (every band). Syntax only (the range needs the file).

    >>> band_numbers("3, 2,1", "reference_bands"), band_numbers(None, "target_bands"), band_numbers(4, "x")
    ((3, 2, 1), None, (4,))
    >>> band_numbers("1,a", "reference_bands")
    Traceback (most recent call last):
    fotogeo.errors.InputError: --reference-bands '1,a': give band numbers from 1, separated by commas (e.g. 1,2,3)
    """
    if value is None:
        return None
    flag = REGISTER[option].cli_flag if option in REGISTER else option
    if isinstance(value, str):
        items = value.replace(",", " ").split()
        numbers = tuple(int(t) for t in items) if all(t.isdigit() for t in items) else None
    else:
        items = list(value) if isinstance(value, (tuple, list, np.ndarray)) else [value]
        whole = all(isinstance(t, (int, np.integer)) and not isinstance(t, bool) for t in items)
        numbers = tuple(int(t) for t in items) if whole else None
    if numbers is None or any(n < 1 for n in numbers):
        raise InputError(f"{flag} {value!r}: give band numbers from 1, separated by commas (e.g. 1,2,3)",
                         option=option)
    if len(set(numbers)) != len(numbers):
        twice = sorted({n for n in numbers if numbers.count(n) > 1})
        raise InputError(f"{flag} {value!r}: band {', '.join(map(str, twice))} given twice; give each band once",
                         option=option)
    return numbers or None


def select_bands(value, count: int, role: str) -> tuple[int, ...]:
    """The band numbers of ``role`` (``reference`` / ``target``) to fuse: ``value`` of its
    ``<role>_bands`` option checked against the ``count`` bands of the file (all when None).

    >>> select_bands("5", 3, "reference")
    Traceback (most recent call last):
    fotogeo.errors.InputError: --reference-bands 5: the reference has 3 bands (1-3); give band numbers in that range
    """
    option = f"{role}_bands"
    numbers = band_numbers(value, option)
    if numbers is None:
        return tuple(range(1, count + 1))
    outside = [n for n in numbers if n > count]
    if outside:
        flag = REGISTER[option].cli_flag if option in REGISTER else option
        given = value if isinstance(value, str) else ",".join(map(str, numbers))
        raise InputError(f"{flag} {given}: the {role} has {count} band{'s' if count > 1 else ''} "
                         f"({'1' if count == 1 else f'1-{count}'}); give band numbers in that range", option=option)
    return numbers


def match_keypoints(kp_tgt, kp_ref, opts):
    """:func:`~fotogeo.features.match.match_descriptors` of two keypoint sets with the options' ratio test."""
    return match_descriptors(kp_tgt.descriptors, kp_ref.descriptors, ratio=opts.ratio, mutual=opts.mutual,
                             laplacian1=kp_tgt.laplacian, laplacian2=kp_ref.laplacian)
