#!/usr/bin/env bash
# Lists the function definitions longer than N lines (default 150) in the C++ files of the
# non-test tree (every *.cc and *.h outside tests/, bench/, fuzz/ and build folders, tracked or
# new), longest first, one per line as FILE:LINE NAME LENGTH (LINE: where the name is; LENGTH:
# lines from there to the closing brace). Usage:
#   scripts/long-functions.sh [N] [FILE|DIR ...]   # default: the non-test tree
# A brace-matching scan with comments, strings, character literals and preprocessor lines taken
# out: a function is a brace at namespace or class scope whose text since the previous ';', '{'
# or '}' holds a parameter list and no '=' outside parentheses (so initialisers are not counted).
# Lambdas and local classes count towards the function that holds them. Exit 0 always.
set -euo pipefail
cd "$(dirname "$0")/.."
limit=150
if [ $# -gt 0 ] && [[ "$1" =~ ^[0-9]+$ ]]; then
  limit="$1"
  shift
fi
files=()
if [ $# -eq 0 ]; then
  while IFS= read -r f; do
    case "$f" in tests/* | bench/* | fuzz/* | build*/*) continue ;; esac
    files+=("$f")
  done < <(git ls-files --cached --others --exclude-standard '*.h' '*.cc' 2>/dev/null || find . -path './build*' -prune -o \( -name '*.h' -o -name '*.cc' \) -print | sed 's|^\./||')
else
  while IFS= read -r f; do files+=("$f"); done < <(find "$@" \( -name '*.h' -o -name '*.cc' \) -print | sort)
fi
[ ${#files[@]} -gt 0 ] || exit 0
python3 - "$limit" "${files[@]}" <<'PY'
import re, sys

def strip(text):
    """Comments, strings, character literals and preprocessor lines replaced by spaces (line breaks kept)."""
    out, i, n = [], 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c in ' \t':
            out.append(c); i += 1; continue
        if line_start and c == '#':  # preprocessor line, with its continuations
            while i < n and text[i] != '\n':
                if text[i] == '\\' and i + 1 < n and text[i + 1] == '\n':
                    out.append('\n'); i += 2; continue
                i += 1
            continue
        line_start = c == '\n'
        if text.startswith('//', i):
            while i < n and text[i] != '\n': i += 1
            continue
        if text.startswith('/*', i):
            j = text.find('*/', i + 2); j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j])); i = j; continue
        m = re.match(r'R"([^ ()\\\t\n]{0,16})\(', text[i:i + 20]) if c == 'R' and (i == 0 or not (text[i-1].isalnum() or text[i-1] == '_')) else None
        if m:
            end = ')' + m.group(1) + '"'
            j = text.find(end, i + m.end()); j = n if j < 0 else j + len(end)
            out.append(re.sub(r'[^\n]', ' ', text[i:j])); i = j; continue
        if c == '"' or (c == "'" and not (i > 0 and text[i-1].isalnum() and i + 1 < n and text[i+1].isalnum())):
            j = i + 1
            while j < n and text[j] != c and text[j] != '\n':
                j += 2 if text[j] == '\\' else 1
            out.append(' ' * (min(j, n - 1) - i + 1)); i = j + 1; continue
        out.append(c); i += 1
    return ''.join(out)

CONTAINER = re.compile(r'^\s*((public|private|protected)\s*:\s*)*(template\s*<.*>\s*)?'
                       r'((inline\s+)?namespace\b|extern\b|(class|struct|union|enum)\b)', re.S)

def top_level(s, opening='(', closing=')'):
    """s with everything inside parentheses removed."""
    depth, out = 0, []
    for ch in s:
        if ch == opening: depth += 1
        elif ch == closing: depth -= 1
        elif depth == 0: out.append(ch)
    return ''.join(out)

def name_of(header):
    """The function's name: the identifier before its parameter list (the first '(' outside <...>)."""
    h = re.sub(r'operator\s*\(\s*\)', 'operator__call', header)
    h = re.sub(r'operator\s*(<<|>>|<=|>=|<|>)', 'operator__cmp', h)
    angle = 0
    for k, ch in enumerate(h):
        if ch == '<': angle += 1
        elif ch == '>': angle = max(0, angle - 1)
        elif ch == '(' and angle == 0:
            m = re.search(r'((?:[\w~]+(?:<[^<>]*>)?::)*(?:operator\s*[^\s\w(]+|operator__\w+|operator\s+\w+|~?\w+))\s*$', h[:k])
            return m.group(1).replace('operator__call', 'operator()') if m else '?'
    return '?'

def scan(path, found):
    text = strip(open(path, encoding='utf-8', errors='replace').read())
    n = len(text)
    line, i = 1, 0
    header, header_start = '', None  # text since the last ';', '{' or '}' (line breaks as spaces)

    def skip_braces(i, line):
        """From the '{' at i to just past its match; returns (index, line)."""
        depth = 0
        while i < n:
            ch = text[i]
            if ch == '\n': line += 1
            elif ch == '{': depth += 1
            elif ch == '}':
                depth -= 1
                if depth == 0: return i + 1, line
            i += 1
        return i, line

    while i < n:
        ch = text[i]
        if ch in ';}':
            header, header_start = '', None
            line += 0; i += 1; continue
        if ch != '{':
            if ch == '\n': line += 1
            if header_start is None and not ch.isspace(): header_start = i
            header += ' ' if ch == '\n' else ch
            i += 1; continue
        h = header.strip()
        if h == '' or (CONTAINER.match(h) and '(' not in top_level(h, '<', '>').split(':')[0]):
            header, header_start = '', None; i += 1; continue  # namespace or class body: scan inside
        flat = top_level(re.sub(r'operator\s*[^\s\w(]+', 'operator', h))
        if '(' not in h or '=' in flat or (re.search(r'\)\s*:(?!:)', h) and re.search(r'[\w>]\s*$', h)):
            # An initialiser (array, aggregate, lambda assigned to a variable) or a member
            # brace-initialiser of a constructor: skipped, the header goes on.
            i, line = skip_braces(i, line)
            header += '{}'; continue
        name = name_of(h)
        short = re.sub(r'<.*', '', name.split('::')[-1])
        span = text[header_start:i]
        m = re.search(re.escape(short) + r'\s*\(', span) if short != '?' else None
        name_line = line - span[m.start():].count('\n') if m else line
        i, end_line = skip_braces(i, line)
        found.append((end_line - name_line + 1, path, name_line, name))
        line = end_line
        header, header_start = '', None

limit = int(sys.argv[1])
found = []
for p in sys.argv[2:]:
    scan(p, found)
for length, path, ln, name in sorted(found, key=lambda t: (-t[0], t[1], t[2])):
    if length > limit:
        print(f'{path}:{ln} {name} {length}')
PY
