"""A screenshot of the viewer page on a stored scene, with an answer highlighted.

Serves the store on 127.0.0.1 (a free port), opens the viewer in headless Chromium
(Debian's ``chromium``, driven by Playwright, WebGL2 through SwiftShader), turns on the
relation types asked for, asks the question, and writes the page as a PNG. Prints what it
measured: the bytes the page fetched, and the seconds until the scene was drawn and until
the answer was.

Usage::

    python scripts/viewer_screenshot.py --db sqlite:///scenes.db --scene scene0000_00 \\
        --ask "Where can I wash my hands?" -o docs/img/viewer.png

Needs ``pip install playwright`` (the ``dev`` extra) and ``apt-get install chromium``; never
run ``playwright install``, the browser is Debian's. See docs/viewer.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FLAGS = ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-dev-shm-usage"]


def main(argv: list[str] | None = None) -> int:
    sys.path.insert(0, str(ROOT))
    from causalsplat import open_store
    from causalsplat.serve import App, Server

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", required=True, help="the store's URL (sqlite:///FILE...)")
    parser.add_argument("--scene", required=True, help="the scene to show")
    parser.add_argument("--ask", default=None, help="a question whose answer is highlighted")
    parser.add_argument("-o", "--output", type=Path, required=True, help="the PNG to write")
    parser.add_argument("--width", type=int, default=1400)
    parser.add_argument("--height", type=int, default=860)
    parser.add_argument(
        "--relations", default=None,
        help="comma-separated relation types to draw (default: the page's own choice)",
    )  # fmt: skip
    parser.add_argument("--max", type=int, default=None, help="the most Gaussians to fetch")
    parser.add_argument(
        "--colors", type=int, default=256,
        help="reduce the PNG to this many colours with pillow (0: keep every colour)",
    )  # fmt: skip
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args(argv)

    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        parser.error("needs playwright: pip install -e '.[dev]'")
    if not Path(args.chromium).is_file():
        parser.error(f"no Chromium at {args.chromium} (apt-get install chromium)")

    with open_store(args.db, create=False) as store:
        store.scene(args.scene)  # an unknown scene fails here, with the store's message
        server = Server(App(store), "127.0.0.1", 0).start()
        try:
            base = server.url.rstrip("/")
            fragment = f"scene={args.scene}" + (f"&max={args.max}" if args.max else "")
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path=args.chromium, args=FLAGS)
                page = browser.new_page(viewport={"width": args.width, "height": args.height})
                problems: list[str] = []
                page.on("pageerror", lambda exc: problems.append(str(exc)))
                page.on("console", lambda m: m.type == "error" and problems.append(m.text))
                start = time.perf_counter()
                page.goto(f"{base}/#{fragment}")
                page.wait_for_function("document.body.dataset.ready === '1'", timeout=600_000)
                ready_s = time.perf_counter() - start
                if args.relations is not None:
                    wanted = {t.strip() for t in args.relations.split(",") if t.strip()}
                    for box in page.locator("#relation-toggles input").all():
                        box.set_checked(box.get_attribute("data-relation") in wanted)
                ask_s = None
                if args.ask:
                    start = time.perf_counter()
                    page.fill("#ask-input", args.ask)
                    page.click("#ask-button")
                    page.wait_for_function(
                        "['done', 'error'].includes(document.body.dataset.ask)", timeout=600_000
                    )
                    ask_s = time.perf_counter() - start
                page.evaluate("() => new Promise(r => requestAnimationFrame(() => "
                              "requestAnimationFrame(r)))")  # fmt: skip
                fetched = page.evaluate(
                    "performance.getEntriesByType('resource')"
                    ".reduce((n, e) => n + e.encodedBodySize, 0)"
                )
                html = page.evaluate(
                    "performance.getEntriesByType('navigation')[0].encodedBodySize"
                )
                splats = page.evaluate("document.body.dataset.splats")
                highlighted = page.evaluate("document.body.dataset.highlighted")
                args.output.parent.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(args.output))
                browser.close()
        finally:
            server.shutdown()
    if args.colors:
        from PIL import Image

        with Image.open(args.output) as image:
            reduced = image.convert("RGB").quantize(args.colors, method=Image.Quantize.FASTOCTREE)
        reduced.save(args.output, optimize=True)
    print(f"wrote {args.output} ({args.output.stat().st_size:,} bytes)")
    print(f"scene {args.scene}: {splats} Gaussians drawn; page fetched {fetched + html:,} bytes; "
          f"drawn {ready_s:.2f} s after it was opened")  # fmt: skip
    if args.ask:
        print(f"asked {args.ask!r}: highlighted [{highlighted}] after {ask_s:.2f} s")
    for problem in problems:
        print(f"page error: {problem}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
