"""scripts/mfot-view in its window, on a headless X server: Xvfb, the viewer playing a log written with
mfot_lcm.write_log, a screenshot of the screen (xwd -root, else ImageMagick's import, else PIL's own
X grab), and the window's pixels judged as test_mfot_view judges a drawing. Skipped with the reason
when Xvfb, tkinter / PIL's ImageTk or every screenshot tool is missing. Nothing sleeps: the viewer says
where its image lies once the X server has drawn it, and the screenshot is retried until it shows
the drawing or the time is up."""

from __future__ import annotations

import os
import queue
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import test_mfot_view as tv  # noqa: E402
import view_scene as vs  # noqa: E402

TIMEOUT_S = 60.0


def window_support() -> str | None:
    """Why the window cannot be tested here, or None."""
    if tv.MISSING:
        return tv.MISSING
    if shutil.which("Xvfb") is None:
        return "needs Xvfb (Debian: xvfb)"
    try:
        import tkinter  # noqa: F401
        from PIL import ImageTk  # noqa: F401
    except ImportError as e:
        return f"needs tkinter and PIL's ImageTk in {sys.executable} (Debian: python3-tk, python3-pil.imagetk): {e}"
    return None


def read_xwd(data: bytes):
    """A PIL image of an xwd dump of a TrueColor 24/32-bit screen (what Xvfb -screen WxHx24 gives)."""
    from PIL import Image

    (header_size, version, pixmap_format, depth, width, height, _xoffset, byte_order, _unit, _unit_order, _pad,
     bits_per_pixel, bytes_per_line, visual_class, red_mask, green_mask, blue_mask, _bits_per_rgb, _entries,
     ncolors, *_rest) = struct.unpack(">25I", data[:100])
    if version != 7 or pixmap_format != 2 or bits_per_pixel != 32 or visual_class not in (4, 5):
        raise ValueError(f"xwd dump not TrueColor ZPixmap 32 bpp (version {version}, format {pixmap_format}, "
                         f"{bits_per_pixel} bpp, class {visual_class})")
    start = header_size + 12 * ncolors
    raw = data[start:start + bytes_per_line * height]
    mode = "BGRX" if byte_order == 0 else "XRGB"
    if (red_mask, green_mask, blue_mask) != (0xFF0000, 0xFF00, 0xFF):
        raise ValueError("xwd dump with unexpected colour masks")
    return Image.frombytes("RGB", (width, height), raw, "raw", mode, bytes_per_line)


def screenshot(display: str):
    """The whole screen as an RGB PIL image, by the first tool that is there."""
    from PIL import Image, ImageGrab

    env = dict(os.environ, DISPLAY=display)
    if shutil.which("xwd"):
        dump = subprocess.run(["xwd", "-root", "-silent"], env=env, capture_output=True, timeout=30, check=True).stdout
        return read_xwd(dump)
    if shutil.which("import"):
        png = subprocess.run(["import", "-window", "root", "png:-"], env=env, capture_output=True, timeout=30,
                             check=True).stdout
        import io

        with Image.open(io.BytesIO(png)) as image:
            return image.convert("RGB")
    return ImageGrab.grab(xdisplay=display).convert("RGB")


def screenshot_tool() -> str | None:
    if shutil.which("xwd"):
        return "xwd"
    if shutil.which("import"):
        return "import"
    try:
        from PIL import features

        return "PIL ImageGrab" if features.check("xcb") else None
    except ImportError:
        return None


class Xvfb:
    """An X server on a free display; its number comes over -displayfd once it accepts clients."""

    def __init__(self, width: int = 640, height: int = 480):
        read_end, write_end = os.pipe()
        self.proc = subprocess.Popen(["Xvfb", "-displayfd", str(write_end), "-screen", "0", f"{width}x{height}x24",
                                      "-nolisten", "tcp"],
                                     pass_fds=(write_end,), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        os.close(write_end)
        number = b""
        with os.fdopen(read_end, "rb") as pipe:
            number = pipe.readline()  # EOF (b"") when Xvfb fails to start
        if not number.strip():
            self.proc.wait(10)
            raise RuntimeError(f"Xvfb did not start: {self.proc.stderr.read().decode(errors='replace')[-500:]}")
        self.display = f":{int(number)}"

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.proc.stderr.close()


def lines_of(proc) -> "queue.Queue[str | None]":
    lines: "queue.Queue[str | None]" = queue.Queue()

    def pump():
        for line in proc.stdout:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=pump, daemon=True).start()
    return lines


@unittest.skipIf(window_support(), window_support())
class WindowTest(unittest.TestCase):
    def setUp(self):
        tool = screenshot_tool()
        if tool is None:
            self.skipTest("no screenshot tool: neither xwd (x11-apps), ImageMagick's import nor PIL with XCB")
        self.types = tv.load_types(self)
        self.tmp = Path(tempfile.mkdtemp(prefix="mfot-view-xvfb-"))
        self.addCleanup(shutil.rmtree, self.tmp, ignore_errors=True)
        self.xvfb = Xvfb()
        self.addCleanup(self.xvfb.close)

    def test_window_shows_the_log(self):
        log = self.tmp / "mfot.lcmlog"
        frames = 3
        vs.write_log(self.types, log, frames=frames)
        env = dict(os.environ, DISPLAY=self.xvfb.display, PYTHONUNBUFFERED="1")
        viewer = subprocess.Popen([sys.executable, str(tv.VIEW), "--log", str(log), "--speed", "0"], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

        def stop_viewer():
            if viewer.poll() is None:
                viewer.send_signal(signal.SIGTERM)
                try:
                    viewer.wait(10)
                except subprocess.TimeoutExpired:
                    viewer.kill()
                    viewer.wait()
            viewer.stdout.close()

        self.addCleanup(stop_viewer)
        lines = lines_of(viewer)
        said = []
        deadline = time.monotonic() + TIMEOUT_S
        where = None
        while where is None:
            left = deadline - time.monotonic()
            self.assertGreater(left, 0, "the viewer never reached the end of the log:\n" + "".join(said))
            try:
                line = lines.get(timeout=left)
            except queue.Empty:
                continue
            self.assertIsNotNone(line, "the viewer exited:\n" + "".join(said))
            said.append(line)
            if "end of log" in line:
                where = line
        self.assertIn(f"{frames} frames shown, last frame {frames - 1}", where)
        position, size = where.split("image at ")[1].split()[:2]
        x, y = (int(c) for c in position.split(","))
        self.assertEqual(size.rstrip(";"), f"{vs.WIDTH}x{vs.HEIGHT}")

        # The X server has the image (the viewer made a round trip after drawing); retry the screenshot
        # until it shows the drawing, in case another client's requests come first.
        failure = None
        while time.monotonic() < deadline:
            screen = screenshot(self.xvfb.display)
            try:
                tv.check_drawing(self, screen, seq=frames - 1, origin=(x, y))
                break
            except AssertionError as e:
                failure = e
        else:
            self.fail(f"the screen never showed the last frame's drawing: {failure}")
        self.assertIsNone(viewer.poll(), "the window closed by itself")


if __name__ == "__main__":
    unittest.main()
