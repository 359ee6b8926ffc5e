#!/usr/bin/env python3
"""Run by CTest (tests/print.cmake): print a report vlt wrote to PDF in headless Chromium on A4 or
US Letter (as a user files it: "print to PDF" with the browser's own header and footer off) and
check every page with pdftotext -bbox-layout (Debian poppler-utils):

- the page number "Page i of N" and the job's name (the report's <title>) on every page;
- no two words overlap (an axis title over a legend, a label over a table): boxes that intersect by
  more than a quarter of the smaller one, on different text lines;
- no word outside the paper (a table or a plot cut off on the right), and the page printed at full
  scale (a probe word of known size: Chromium shrinks a page whose content is too wide instead).

usage: check_print.py CHROMIUM REPORT.html OUT_DIR A4|Letter
"""
import html
import os
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

PAPER = {"A4": (595.0, 842.0), "Letter": (612.0, 792.0)}
# The window is a desktop's, wider than the paper: the report must redraw its plots at the paper's
# width when printing (its beforeprint handler), not rely on having been drawn there.
WINDOW = "1400,1000"
# A 10 px probe word, printed at full scale, is about 8.7 pt tall in pdftotext's boxes; a page that
# Chromium had to shrink to fit something too wide prints it smaller.
PROBE = "vltprintscaleprobe"
PROBE_MIN_HEIGHT_PT = 8.0


def print_pdf(chromium, report, out, paper):
    os.makedirs(out, exist_ok=True)
    text = open(report, encoding="utf-8").read()
    # The paper the user picks in the print dialog; the report itself does not force one.
    text = text.replace("</head>", f"<style>@page{{size:{paper}}}</style></head>", 1)
    text = text.replace("</body>", f'<p style="font-size:10px;margin:0">{PROBE}</p></body>', 1)
    page = os.path.join(out, f"print-{paper}.html")
    open(page, "w", encoding="utf-8").write(text)
    pdf = os.path.join(out, f"print-{paper}.pdf")
    profile = os.path.join(out, f"chromium-profile-{paper}")
    shutil.rmtree(profile, ignore_errors=True)
    done = subprocess.run(
        [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
         f"--user-data-dir={profile}", f"--window-size={WINDOW}", "--virtual-time-budget=60000", "--run-all-compositor-stages-before-draw",
         "--no-pdf-header-footer", f"--print-to-pdf={pdf}", "file://" + os.path.abspath(page)],
        capture_output=True, text=True, timeout=240)
    shutil.rmtree(profile, ignore_errors=True)
    if done.returncode != 0 or not os.path.exists(pdf):
        sys.exit(f"chromium could not print {report} (exit {done.returncode}):\n{done.stderr[-2000:]}")
    return pdf, text


def pages_of(pdf):
    xhtml = subprocess.run(["pdftotext", "-bbox-layout", pdf, "-"], capture_output=True, text=True, check=True).stdout
    xhtml = re.sub(r"<!DOCTYPE[^>]*>", "", xhtml)
    xhtml = re.sub(r'xmlns="[^"]*"', "", xhtml, count=1)
    root = ET.fromstring(xhtml)
    pages = []
    for page in root.iter("page"):
        lines = []
        for line in page.iter("line"):
            words = [(float(w.get("xMin")), float(w.get("yMin")), float(w.get("xMax")), float(w.get("yMax")), w.text or "")
                     for w in line.iter("word")]
            lines.append(words)
        pages.append((float(page.get("width")), float(page.get("height")), lines))
    return pages


def overlaps(lines):
    # Every pair of words, on one text line or not: pdftotext may merge words of different elements
    # that overlap into one line. Neighbours on a line touch at most (1 pt of kerning is allowed).
    found = []
    words = [w for line in lines for w in line]
    for a in range(len(words)):
        ax0, ay0, ax1, ay1, at = words[a]
        for b in range(a + 1, len(words)):
            bx0, by0, bx1, by1, bt = words[b]
            w = min(ax1, bx1) - max(ax0, bx0)
            h = min(ay1, by1) - max(ay0, by0)
            if w <= 1.0 or h <= 0:
                continue
            smaller = min((ax1 - ax0) * (ay1 - ay0), (bx1 - bx0) * (by1 - by0))
            if smaller > 0 and w * h > 0.25 * smaller:
                found.append(f"'{at}' at ({ax0:.0f}, {ay0:.0f}) over '{bt}' at ({bx0:.0f}, {by0:.0f})")
    return found


def main():
    chromium, report, out, paper = sys.argv[1:5]
    pdf, text = print_pdf(chromium, report, out, paper)
    title = html.unescape(re.search(r"<title>(.*?)</title>", text, re.S).group(1)).strip()
    title_words = title.split()
    pages = pages_of(pdf)
    problems = []
    probe_found = [False]
    for n, (width, height, lines) in enumerate(pages, start=1):
        if abs(width - PAPER[paper][0]) > 2 or abs(height - PAPER[paper][1]) > 2:
            problems.append(f"page {n}: {width:.0f} x {height:.0f} pt, not {paper}")
        flat = [w[4] for line in lines for w in line]
        joined = " ".join(flat)
        if f"Page {n} of {len(pages)}" not in joined:
            problems.append(f"page {n}: no 'Page {n} of {len(pages)}'")
        if " ".join(title_words[:6]) not in joined:
            problems.append(f"page {n}: the job's name '{title}' is not on it")
        for line in lines:
            for x0, y0, x1, y1, t in line:
                if x0 < -1 or x1 > width + 1 or y1 > height + 1:
                    problems.append(f"page {n}: '{t}' lies outside the paper ({x0:.0f}..{x1:.0f} of {width:.0f} pt)")
        problems += [f"page {n}: {o}" for o in overlaps(lines)]
        for line in lines:
            for x0, y0, x1, y1, t in line:
                if t == PROBE and y1 - y0 < PROBE_MIN_HEIGHT_PT:
                    problems.append(f"page {n}: printed at {100 * (y1 - y0) / 8.7:.0f} % scale (something is too wide for the paper)")
        flat = [w[4] for line in lines for w in line]
        if PROBE in flat:
            probe_found[0] = True
    if not probe_found[0]:
        problems.append("the scale probe was not printed")
    if problems:
        sys.exit(f"{report} on {paper}, {len(pages)} pages:\n  " + "\n  ".join(problems[:40]))
    print(f"ok: {report} prints on {paper}: {len(pages)} pages, numbered, named, no overlapping words")


if __name__ == "__main__":
    main()
