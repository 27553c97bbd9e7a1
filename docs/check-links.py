#!/usr/bin/env python3
"""Check the documentation's references: every relative link in README.md,
experiments/README.md and docs/*.md resolves to a file (and its #anchor to a heading of that
file, as GitHub makes anchors), and every repository path quoted in
backticks (`src/…`, `tests/…`, `policies/…`, …) exists.

    python3 docs/check-links.py        # from the repository root; exit 1 on a broken reference
"""
import glob
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAGES = [os.path.join(ROOT, 'README.md'), os.path.join(ROOT, 'experiments', 'README.md')] + sorted(glob.glob(os.path.join(ROOT, 'docs', '*.md')))
# Quoted paths that name a file a command writes or a placeholder, not a
# file of the repository.
PATH_PREFIXES = ('src/', 'tests/', 'benches/', 'examples/', 'experiments/', 'policies/',
                 'scenarios/', 'scripts/', 'docs/', '.ci/')
LINK = re.compile(r'\[[^\]]*\]\(([^)\s]+)\)')
CODE = re.compile(r'`([^`\n]+)`')


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped,
    spaces to hyphens."""
    text = heading.strip().lower()
    text = re.sub(r'[^\w\- ]', '', text)
    return text.replace(' ', '-')


def anchors(path):
    found, fence, seen = set(), False, {}
    for line in open(path, encoding='utf-8'):
        if line.startswith('```'):
            fence = not fence
        if fence:
            continue
        m = re.match(r'#{1,6} (.*)', line)
        if m:
            s = slug(m.group(1))
            n = seen.get(s, 0)
            found.add(s if n == 0 else f'{s}-{n}')
            seen[s] = n + 1
    return found


def outside_fences(text):
    out, fence = [], False
    for line in text.split('\n'):
        if line.startswith('```'):
            fence = not fence
            continue
        out.append('' if fence else line)
    return '\n'.join(out)


errors = []
for page in PAGES:
    rel_page = os.path.relpath(page, ROOT)
    text = open(page, encoding='utf-8').read()
    body = outside_fences(text)
    for target in LINK.findall(body):
        if re.match(r'[a-z]+:', target):
            continue
        path, _, anchor = target.partition('#')
        full = os.path.normpath(os.path.join(os.path.dirname(page), path)) if path else page
        if not os.path.exists(full):
            errors.append(f'{rel_page}: link {target}: no file {os.path.relpath(full, ROOT)}')
            continue
        if anchor and full.endswith('.md') and anchor not in anchors(full):
            errors.append(f'{rel_page}: link {target}: no heading #{anchor}')
    for code in CODE.findall(body):
        for word in re.findall(r'[\w./-]+', code):
            word = word.rstrip('.,;:')
            if not word.startswith(PATH_PREFIXES) or any(c in word for c in '…*'):
                continue
            if not os.path.exists(os.path.join(ROOT, word)):
                errors.append(f'{rel_page}: quoted path `{word}` does not exist')

for e in errors:
    print(e)
print(f'{len(PAGES)} pages checked, {len(errors)} broken reference(s)')
sys.exit(1 if errors else 0)
