"""The report in a real browser: headless Chromium opens it with the network cut off,
and a checking script (added to a copy of the page, not to the report) records every
script error and console error, whether each image decoded (naturalWidth > 0), whether
the animation drew on its canvas and whether its slider moves it. Also --pdf through the
same browser.

Skipped only when no Chromium-based browser is installed (CI installs Debian's
``chromium``: ``apt-get install -y chromium``)."""

from __future__ import annotations

import html
import json
import os
import re
import subprocess
import tempfile

import pytest
from click.testing import CliRunner

from mechsolve.cli.commands.report import report
from mechsolve.report.browser import find_browser, headless_command

from conftest import MECH

BROWSER = find_browser()
IN_CI = os.environ.get("CI", "").lower() not in ("", "0", "false", "no")
if BROWSER is None and IN_CI:  # CI installs chromium (.ci/run): never skip there
    raise RuntimeError("CI must install a Chromium-based browser (.ci/run: chromium)")
pytestmark = pytest.mark.skipif(
    BROWSER is None, reason="no Chromium-based browser (apt-get install -y chromium)"
)

# collects errors from the very start of the page
CATCH = """<script>
window.__errors = [];
window.addEventListener("error", function (e) {
  window.__errors.push("error: " + (e.message || (e.target && (e.target.src || e.target.tagName))));
}, true);
window.addEventListener("unhandledrejection", function (e) {
  window.__errors.push("rejection: " + e.reason);
});
(function () {
  var orig = console.error;
  console.error = function () {
    window.__errors.push("console: " + Array.prototype.join.call(arguments, " "));
    orig.apply(console, arguments);
  };
})();
</script>"""

# runs after the page has loaded, writes its findings into the DOM that --dump-dom prints
CHECK = """<script>
window.addEventListener("load", function () {
  var out = {errors: window.__errors, images: []};
  Array.prototype.forEach.call(document.images, function (im) {
    out.images.push({alt: im.alt, complete: im.complete, width: im.naturalWidth});
  });
  var canvas = document.getElementById("player-canvas");
  if (canvas) {
    var px = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
    var inked = 0;
    for (var i = 3; i < px.length; i += 4) { if (px[i] > 0) { inked++; } }
    out.inked = inked;
    var slider = document.getElementById("player-slider");
    slider.value = "5";
    slider.dispatchEvent(new Event("input"));
    out.frame = document.getElementById("player").getAttribute("data-frame");
    out.label = document.getElementById("player-label").textContent;
    var box = document.getElementById("player-forces");
    if (box) {
      box.checked = true;
      box.dispatchEvent(new Event("change"));
      var px2 = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
      var red = 0;
      for (i = 0; i < px2.length; i += 4) {
        if (px2[i] > 200 && px2[i + 1] < 60 && px2[i + 2] < 60) { red++; }
      }
      out.red = red;
    }
    document.getElementById("player-play").click();
  }
  var pre = document.createElement("pre");
  pre.id = "browser-check";
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


def open_in_browser(html_path, tmp_path) -> tuple[dict, str]:
    text = html_path.read_text(encoding="utf-8")
    text = text.replace("<head>", "<head>\n" + CATCH, 1).replace("</body>", CHECK + "</body>", 1)
    copy = tmp_path / "checked.html"
    copy.write_text(text, encoding="utf-8")
    with tempfile.TemporaryDirectory() as profile:
        cmd = headless_command(
            BROWSER,
            profile,
            "--host-resolver-rules=MAP * ~NOTFOUND",  # no network: a fetch would fail
            "--virtual-time-budget=5000",
            "--enable-logging=stderr",
            "--v=0",
            "--dump-dom",
            copy.as_uri(),
        )
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    m = re.search(r'<pre id="browser-check">(.*?)</pre>', p.stdout, re.S)
    assert m, f"the page did not finish loading:\n{p.stderr[-2000:]}"
    return json.loads(html.unescape(m.group(1))), p.stderr


@pytest.fixture(scope="module")
def crane_report(tmp_path_factory):
    d = tmp_path_factory.mktemp("browser")
    out = d / "crane.html"
    r = CliRunner().invoke(
        report, [str(MECH / "crane.yaml"), "-o", str(out), "--frames", "24", "--pdf", "-q"]
    )
    assert r.exit_code == 0, r.output
    return out


def test_the_report_renders_without_errors_and_every_image_loads(crane_report, tmp_path):
    found, log = open_in_browser(crane_report, tmp_path)
    assert found["errors"] == []
    assert not re.search(r"Uncaught|CONSOLE\(\d+\).*[Ee]rror", log)
    n_img = crane_report.read_text(encoding="utf-8").count("<img ")
    assert len(found["images"]) == n_img >= 10
    for im in found["images"]:
        assert im["complete"] and im["width"] > 100, im
    # the animation: drawn, moved by the slider, the forces shown on request
    assert found["inked"] > 5000
    assert found["frame"] == "5"
    assert found["label"].startswith(f"driver O1 = {5 * 360 / 23:.1f}°, t = ")  # 24 frames
    assert found["red"] > 50


def test_pdf_through_the_browser(crane_report):
    pdf = crane_report.with_suffix(".pdf")
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF-")
    assert len(re.findall(rb"/Type\s*/Page[^s]", data)) >= 5  # a multi-page document
