"""Text in the users' languages on plots: Chinese, Japanese, Korean and Cyrillic names.

matplotlib draws with DejaVu Sans, which has Latin, Greek and Cyrillic but no CJK glyphs:
a name such as ``码头吊车机构`` would come out as empty boxes, with one ``UserWarning`` per
glyph. :func:`pyplot` puts the CJK fonts the system has (Noto Sans CJK, Source Han Sans,
WenQuanYi, SimHei, Microsoft YaHei, PingFang ...) behind DejaVu Sans in matplotlib's
font fallback, keeps text as text in SVG, and, when no installed font can draw some of the
given texts, says once what to install instead of a warning per glyph.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterable
from typing import Any

__all__ = ["configure", "missing_characters", "pyplot"]

# CJK fonts by preference (Simplified Chinese first: the founding documents' language)
FALLBACKS = (
    "Noto Sans CJK SC",
    "Noto Sans CJK JP",
    "Noto Sans CJK TC",
    "Noto Sans CJK KR",
    "Source Han Sans SC",
    "Source Han Sans CN",
    "Source Han Sans",
    "WenQuanYi Micro Hei",
    "WenQuanYi Zen Hei",
    "Droid Sans Fallback",
    "Microsoft YaHei",
    "SimHei",
    "PingFang SC",
    "Hiragino Sans GB",
    "Heiti SC",
    "Noto Sans SC",
    "Noto Sans JP",
    "Noto Sans KR",
    "Malgun Gothic",
    "Yu Gothic",
    "IPAexGothic",
    "IPAGothic",
    "AR PL UMing CN",
    "Arial Unicode MS",
)
INSTALL_HINT = (
    "install a CJK font: Debian/Ubuntu 'apt-get install fonts-noto-cjk' (or the smaller "
    "fonts-wqy-microhei), Fedora 'dnf install google-noto-sans-cjk-fonts'; Windows and "
    "macOS have one"
)

_state: dict[str, Any] = {"families": None, "charmaps": None, "noted": set()}


def configure() -> list[str]:
    """Set matplotlib's font families once: DejaVu Sans, then every installed CJK font of
    :data:`FALLBACKS` (glyphs missing from one are looked for in the next). Returns the
    families."""
    if _state["families"] is not None:
        return _state["families"]
    from matplotlib import font_manager, rcParams

    installed = {f.name for f in font_manager.fontManager.ttflist}
    families = ["DejaVu Sans", *[n for n in FALLBACKS if n in installed]]
    rcParams["font.family"] = families
    rcParams["svg.fonttype"] = "none"  # text stays text in SVG: the viewer's fonts draw it
    _state["families"] = families
    return families


def _charmaps() -> list[set[int]]:
    if _state["charmaps"] is None:
        from matplotlib import font_manager
        from matplotlib.ft2font import FT2Font

        maps = []
        for fam in configure():
            try:
                path = font_manager.findfont(
                    font_manager.FontProperties(family=fam), fallback_to_default=False
                )
                maps.append(set(FT2Font(path).get_charmap()))
            except (ValueError, RuntimeError, OSError):
                continue
        _state["charmaps"] = maps
    return _state["charmaps"]


def missing_characters(texts: Iterable[str]) -> list[str]:
    """The characters of ``texts`` that no configured font can draw, in order."""
    maps = _charmaps()
    out: list[str] = []
    for text in texts:
        for ch in str(text):
            if ch.isspace() or ch in out:
                continue
            if not any(ord(ch) in m for m in maps):
                out.append(ch)
    return out


def pyplot(texts: Iterable[str] = ()):
    """matplotlib's pyplot on the Agg backend with the fonts configured; when ``texts``
    (the names a plot will show) have characters no installed font draws, one note on
    stderr says what to install, and matplotlib's per-glyph warnings are silenced."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    configure()
    missing = missing_characters(texts)
    if missing:
        warnings.filterwarnings("ignore", message=r"Glyph \d+ .*missing from", category=UserWarning)
        key = "".join(missing)
        if key not in _state["noted"]:
            _state["noted"].add(key)
            shown = "".join(missing[:12]) + ("..." if len(missing) > 12 else "")
            sys.stderr.write(
                f"note: no installed font can draw {shown!r}; the plots show boxes for "
                f"them: {INSTALL_HINT}\n"
            )
    return plt
