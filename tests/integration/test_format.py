#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""What .editorconfig promises, over every tracked text file: LF line ends, a final newline, no trailing
blanks (Markdown may end a line with two for a break), no tabs in code, an SPDX line in the first five
lines of every code file. Usage: test_format.py SOURCE_ROOT"""
import os
import re
import subprocess
import sys

CODE = ('.c', '.h', '.cpp', '.hpp', '.sh', '.py', '.build', '.js')
os.chdir(sys.argv[1])
try:
    files = subprocess.run(['git', 'ls-files', '-z'], check=True, capture_output=True).stdout.decode().split('\0')
except (OSError, subprocess.CalledProcessError):
    print('SKIP: not a git checkout')
    sys.exit(77)
fails = 0
for f in filter(None, files):
    if not os.path.isfile(f) or f.startswith('tests/fuzz/corpus/'):
        continue  # fuzz inputs are data: CR line ends and a missing newline are part of what they test
    data = open(f, 'rb').read()
    if not data or b'\0' in data[:8192]:
        continue  # empty or binary
    problems = []
    if not data.endswith(b'\n'):
        problems.append('no newline at the end')
    if b'\r' in data:
        problems.append('CR line ends')
    lines = data.split(b'\n')
    md = f.endswith('.md')
    for i, line in enumerate(lines, 1):
        if md and re.search(rb'\S  $', line):
            continue  # a Markdown line break
        if re.search(rb'[ \t]+$', line):
            problems.append('trailing blanks on line %d' % i)
            break
    if f.endswith(CODE) or os.path.basename(f) == 'meson.build':
        tab = next((i for i, line in enumerate(lines, 1) if b'\t' in line), 0)
        if tab:
            problems.append('a tab on line %d' % tab)
        if b'SPDX-License-Identifier' not in b'\n'.join(lines[:5]):
            problems.append('no SPDX line in its first 5 lines')
    for p in problems:
        print('FAIL: %s: %s' % (f, p))
    fails += len(problems)
if not fails:
    print('format: %d files checked' % len(files))
sys.exit(1 if fails else 0)
