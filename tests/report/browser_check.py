#!/usr/bin/env python3
"""Opens a `vdbmap report` page in headless Chromium (Debian's, WebGL through SwiftShader) and
checks what a person would see: the page loads without errors, the 3D canvas draws the map (pixel
statistics of the canvas region in a screenshot, and the page's own count of drawn pixels), and
the plots and figures hold the run's numbers (read back from the DOM against the run's files).

  browser_check.py --vdbmap BIN --workdir DIR
      runs a short `vdbmap explore --report` in DIR and checks its report (the CTest entry);
  browser_check.py REPORT.html [--run RUNDIR] [--screenshot OUT.png]
      checks an existing page (against RUNDIR's files when given) and keeps the screenshot.

Exit status: 0 passed, 1 failed, 77 skipped (no Chromium, or no Pillow to read its screenshot).
"""
import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
from html.parser import HTMLParser

SKIP = 77
WINDOW = (1280, 2400)


class Elements(HTMLParser):
    """Every start tag with its attributes, in document order, and the text of #report-errors."""

    def __init__(self):
        super().__init__()
        self.elements = []
        self.errors_text = ''
        self._in_errors = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.elements.append((tag, a))
        self._in_errors = a.get('id') == 'report-errors'

    def handle_endtag(self, tag):
        self._in_errors = False

    def handle_data(self, data):
        if self._in_errors:
            self.errors_text += data

    def find(self, tag=None, **attrs):
        return [a for t, a in self.elements
                if (tag is None or t == tag) and all(a.get(k.replace('_', '-')) == v for k, v in attrs.items())]


def chromium():
    return os.environ.get('CHROMIUM') or shutil.which('chromium') or shutil.which('chromium-browser')


def run_chromium(browser, page, profile, *args):
    cmd = [browser, '--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run',
           '--enable-logging=stderr', '--v=0', f'--user-data-dir={profile}',
           f'--window-size={WINDOW[0]},{WINDOW[1]}', '--virtual-time-budget=10000', *args,
           'file://' + os.path.abspath(page)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180)


failures = []


def check(condition, what):
    print(('ok    ' if condition else 'FAIL  ') + what)
    if not condition:
        failures.append(what)


def close(a, b, tol):
    return a is not None and b is not None and abs(float(a) - float(b)) <= tol


def check_page(page, run_dir, screenshot):
    browser = chromium()
    if not browser:
        print('skipped: chromium is not installed (scripts/test.sh installs it)')
        return SKIP
    try:
        from PIL import Image
    except ImportError:
        print('skipped: Pillow (python3-pil) is not installed (scripts/test.sh installs it)')
        return SKIP
    with tempfile.TemporaryDirectory() as tmp:
        dom_run = run_chromium(browser, page, os.path.join(tmp, 'p1'), '--dump-dom')
        shot = screenshot or os.path.join(tmp, 'page.png')
        shot_run = run_chromium(browser, page, os.path.join(tmp, 'p2'), f'--screenshot={shot}')
        check(dom_run.returncode == 0 and shot_run.returncode == 0, 'chromium ran')
        dom = Elements()
        dom.feed(dom_run.stdout)
        console = [line for line in (dom_run.stderr + shot_run.stderr).splitlines() if 'CONSOLE' in line]
        bad_console = [line for line in console if 'Uncaught' in line or 'rror' in line]
        check(not bad_console, 'no console errors' + (': ' + ' | '.join(bad_console[:3]) if bad_console else ''))
        html = dom.find('html')
        check(bool(html) and html[0].get('data-status') == 'ready',
              f"page status ready (got {html[0].get('data-status') if html else None})")
        check(dom.errors_text.strip() == '', 'no errors shown on the page' +
              (': ' + dom.errors_text.strip()[:300] if dom.errors_text.strip() else ''))

        # The 3D view: the page's own count, and the screenshot's canvas region.
        canvas = dom.find('canvas', id='view3d')
        check(bool(canvas), '3D canvas present')
        if canvas:
            drawn = float(canvas[0].get('data-drawn-fraction', 0))
            check(drawn >= 0.03, f'the first frame drew {drawn:.3f} of the canvas (>= 0.03)')
            x, y, w, h = (int(v) for v in canvas[0]['data-rect'].split(','))
            img = Image.open(shot).convert('RGB')
            region = img.crop((x, y, min(x + w, img.width), min(y + h, img.height)))
            pixels = list(region.getdata())
            non_white = sum(1 for p in pixels if min(p) < 245) / max(1, len(pixels))
            colours = len(set(pixels))
            check(non_white >= 0.03, f'screenshot: {non_white:.3f} of the canvas region is drawn (>= 0.03)')
            check(colours >= 100, f'screenshot: {colours} distinct colours in the canvas region (>= 100: shading, not a fill)')

        if not run_dir:
            return 1 if failures else 0
        # The run's numbers, read back from the page.
        summary = json.load(open(os.path.join(run_dir, 'summary.json')))
        figures = {a.get('data-label'): json.loads(a.get('data-value')) for a in dom.find('div', **{'class': 'figure'})}
        check(close(figures.get('coverage at finish'), summary['coverage'], 1e-4),
              f"figure coverage {figures.get('coverage at finish')} = summary {summary['coverage']:.5f}")
        check(figures.get('loop closures') == summary['loop_closures'], 'figure loop closures = summary')
        check(figures.get('collision events') == summary['collisions'], 'figure collision events = summary')
        rows = list(csv.DictReader(open(os.path.join(run_dir, 'coverage.csv'))))
        cov = dom.find('svg', data_plot_id='coverage')
        series = [a for t, a in dom.elements if t == 'g' and a.get('data-series') == 'coverage']
        check(bool(cov) and bool(series), 'coverage plot drawn')
        if series:
            check(int(series[0]['data-n']) == len(rows), f"coverage plot has {series[0]['data-n']} points = {len(rows)} rows")
            check(close(series[0]['data-last'], rows[-1]['coverage'], 1e-4),
                  f"coverage plot ends at {series[0]['data-last']} = coverage.csv {rows[-1]['coverage']}")
        loops = summary['loop_closures']
        marks = [a for t, a in dom.elements if t == 'line' and a.get('class') == 'mark']
        plots_with_marks = 4 if loops else 0  # coverage, estimate error, mapper cycle, queue
        check(len(marks) == plots_with_marks * loops, f'{len(marks)} loop-closure marks = {plots_with_marks} plots x {loops}')
        cycles = list(csv.DictReader(open(os.path.join(run_dir, 'cycles.csv'))))
        replans = sum(1 for r in cycles if float(r['planner_ms']) > 0)
        planner = [a for t, a in dom.elements if t == 'g' and a.get('data-series') == 'replan']
        check(bool(planner) and int(planner[0]['data-n']) == replans, f'planner plot holds the {replans} replans')
        bars = [a for t, a in dom.elements if t == 'rect' and a.get('class') == 'bar']
        activity = sum(float(a['data-value']) for a in bars if a.get('data-group') == 'time (s)')
        check(close(activity, summary['exploration_time_s'], 0.2),
              f"activity bars sum to {activity:.2f} s = exploration time {summary['exploration_time_s']:.2f} s")
    return 1 if failures else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('page', nargs='?', help='a report page to check')
    parser.add_argument('--run', help='the run folder the page was made from (checks its numbers)')
    parser.add_argument('--screenshot', help='keep the screenshot here')
    parser.add_argument('--vdbmap', help='the vdbmap program: make a short explore run with --report and check it')
    parser.add_argument('--workdir', help='where the short run goes (with --vdbmap)')
    a = parser.parse_args()
    if a.vdbmap:
        if not chromium():
            print('skipped: chromium is not installed (scripts/test.sh installs it)')
            return SKIP
        run_dir = os.path.join(a.workdir or tempfile.mkdtemp(), 'run')
        made = subprocess.run([a.vdbmap, 'explore', '--drift', 's3', '--alc', 'on', '--max-time-s', '45', '--report',
                               '--overwrite', '-o', run_dir], capture_output=True, text=True)
        print(made.stdout)
        if made.returncode != 0:
            print(made.stderr)
            return 1
        return check_page(os.path.join(run_dir, 'report.html'), run_dir, a.screenshot)
    if not a.page:
        parser.error('give a page, or --vdbmap')
    return check_page(a.page, a.run, a.screenshot)


if __name__ == '__main__':
    sys.exit(main())
