#!/usr/bin/env python3
"""Check that every relative link in the documentation resolves.

Reads README.md, CHANGELOG.md and docs/**/*.md (from the repository root, wherever it is called
from). For every Markdown link or image `[text](target)` and every reference definition
`[label]: target` whose target is relative (no scheme such as https:, no mailto:), the file or
directory must exist, relative to the page, inside the repository; a `#anchor` (alone, or after
a .md file) must name a heading of that page, slugged as GitHub does (lower case, punctuation
dropped, spaces to hyphens, a -1, -2 … suffix for repeats). Links inside code spans and fenced
code blocks are not links and are skipped. External links are not fetched (CI has no network to
spare); they are listed with --external.

Exit status 0 when every link resolves, 1 with one line per broken link (file:line: target:
why) otherwise. Written by hand: the Markdown link checkers on PyPI either fetch every URL or
need Node; this needs only the standard library.
"""

import pathlib
import re
import sys
import unicodedata

ROOT = pathlib.Path(__file__).resolve().parent.parent
FENCE = re.compile(r"^\s*(```|~~~)")
CODE_SPAN = re.compile(r"(`+)(?:(?!\1).)+?\1")
INLINE = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFDEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
HTML_ANCHOR = re.compile(r"<a\s+(?:name|id)=\"([^\"]+)\"")
SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def pages():
    """The documentation pages, repository-relative, sorted."""
    found = [ROOT / "README.md", ROOT / "CHANGELOG.md"]
    found += sorted((ROOT / "docs").rglob("*.md"))
    return [p for p in found if p.is_file()]


def slug(heading):
    """GitHub's anchor for a heading's text."""
    text = re.sub(r"`([^`]*)`", r"\1", heading)
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link's text only
    text = re.sub(r"<[^>]+>", "", text)
    text = text.strip().lower()
    out = []
    for ch in text:
        cat = unicodedata.category(ch)
        if ch in " -":
            out.append("-" if ch == " " else ch)
        elif ch == "_" or cat[0] in "LN" or cat == "Mn":
            out.append(ch)
    return "".join(out)


def lines_outside_code(path):
    """(line number, text with code spans blanked) for every line outside fenced code."""
    in_fence = None
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = FENCE.match(line)
        if m:
            if in_fence is None:
                in_fence = m.group(1)
            elif m.group(1) == in_fence:
                in_fence = None
            continue
        if in_fence is None:
            yield n, CODE_SPAN.sub(lambda s: " " * len(s.group(0)), line)


_anchors = {}


def anchors(path):
    """The anchors a page defines: its headings' slugs (numbered on repeats) and HTML anchors."""
    if path not in _anchors:
        seen = {}
        found = set()
        in_fence = None
        for line in path.read_text(encoding="utf-8").splitlines():
            m = FENCE.match(line)
            if m:
                if in_fence is None:
                    in_fence = m.group(1)
                elif m.group(1) == in_fence:
                    in_fence = None
                continue
            if in_fence is not None:
                continue
            found.update(HTML_ANCHOR.findall(line))
            h = HEADING.match(line)
            if h:
                s = slug(h.group(2))
                k = seen.get(s, 0)
                found.add(s if k == 0 else f"{s}-{k}")
                seen[s] = k + 1
        _anchors[path] = found
    return _anchors[path]


def targets(path):
    """(line, target) for every link and reference definition of a page."""
    for n, line in lines_outside_code(path):
        for m in INLINE.finditer(line):
            yield n, m.group(1)
        m = REFDEF.match(line)
        if m:
            yield n, m.group(1)


def check(path, target):
    """None when `target`, linked from `path`, resolves; else why not."""
    if target.startswith("#"):
        file, anchor = path, target[1:]
    else:
        link, _, anchor = target.partition("#")
        link = link.split("?", 1)[0]
        file = (path.parent / link).resolve()
        try:
            file.relative_to(ROOT)
        except ValueError:
            return "points outside the repository"
        if not file.exists():
            return "no such file or directory"
    if anchor:
        if file.is_dir() or file.suffix.lower() != ".md":
            return None  # an anchor into a non-Markdown file (e.g. a source line): not checked
        if anchor.lower() not in {a.lower() for a in anchors(file)}:
            return f"no heading with anchor #{anchor} in {file.relative_to(ROOT)}"
    return None


def main(argv):
    show_external = "--external" in argv
    broken = 0
    checked = 0
    for page in pages():
        for n, target in targets(page):
            rel = page.relative_to(ROOT)
            if SCHEME.match(target):
                if show_external and not target.startswith("mailto:"):
                    print(f"{rel}:{n}: external {target}")
                continue
            checked += 1
            why = check(page, target)
            if why:
                broken += 1
                print(f"{rel}:{n}: {target}: {why}")
    if broken:
        print(f"check-links: {broken} of {checked} relative links are broken", file=sys.stderr)
        return 1
    print(f"check-links: {checked} relative links in {len(pages())} pages resolve")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
