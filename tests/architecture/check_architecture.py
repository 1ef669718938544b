#!/usr/bin/python3
"""The architecture the build enforces (docs/architecture.md).

    check_architecture.py includes  SOURCE_DIR
    check_architecture.py symbols   SOURCE_DIR LIB_DIR_OR_FILES...
    check_architecture.py functions SOURCE_DIR [--limit 150]
    check_architecture.py selftest

includes   Every file of a stage (src/<stage>/, include/locard/<stage>/; tests and test helpers
           excepted) includes headers of its own stage or of the stages src/CMakeLists.txt says
           it builds on (locard_<stage>_stages, followed transitively) - never a later stage's.
symbols    No stage library needs a symbol that only a stage it may not use defines: `nm` on each
           built libLocard_<stage>.a; an undefined symbol found defined only in a forbidden
           stage's library is a back-edge the includes could hide (a forward declaration).
functions  No function in src/ or apps/ (tests included) runs over the limit in lines, from the
           line its signature starts on to its closing brace.

selftest   Each check run on a small made-up tree that breaks it, and on one that does not.

Exit 1 naming each violation with its file and line; 0 when clean; 2 on bad usage.
"""
import collections
import os
import re
import subprocess
import sys


def stage_graph(source_dir):
    """The stages, lowest first, and the stages each may use (transitive), from src/CMakeLists.txt."""
    text = open(os.path.join(source_dir, 'src', 'CMakeLists.txt')).read()
    m = re.search(r'set\(LOCARD_STAGES ([a-z ]+?)\s*\n?\s*CACHE', text)
    if not m:
        sys.exit('check_architecture: no LOCARD_STAGES list in src/CMakeLists.txt')
    stages = m.group(1).split()
    direct = {}
    for stage in stages:
        d = re.search(r'set\(locard_%s_stages([a-z ]*)\)' % stage, text)
        if d is None:
            sys.exit(f'check_architecture: src/CMakeLists.txt has no locard_{stage}_stages')
        direct[stage] = d.group(1).split()
    order = {s: i for i, s in enumerate(stages)}
    allowed = {}
    for stage in stages:  # lowest first, so the closure of each used stage is known
        closure = set()
        for used in direct[stage]:
            if used not in order or order[used] >= order[stage]:
                sys.exit(f'check_architecture: src/CMakeLists.txt: {stage} may not build on '
                         f'{used} (not a stage before it)')
            closure |= {used} | allowed[used]
        allowed[stage] = closure
    return stages, allowed


def is_test_file(name):
    return name.endswith('_test.cpp') or 'test_util' in name or name.startswith('test_')


INCLUDE = re.compile(r'^\s*#\s*include\s*[<"](?:locard/)?([a-z_]+)/([^>"]+)[>"]')


def check_includes(source_dir):
    stages, allowed = stage_graph(source_dir)
    problems = []
    for stage in stages:
        for base in (os.path.join('src', stage), os.path.join('include', 'locard', stage)):
            folder = os.path.join(source_dir, base)
            if not os.path.isdir(folder):
                continue
            for name in sorted(os.listdir(folder)):
                if is_test_file(name) or not name.endswith(('.cpp', '.hpp', '.h')):
                    continue
                path = os.path.join(base, name)
                with open(os.path.join(source_dir, path), errors='replace') as f:
                    for number, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m or m.group(1) not in stages or m.group(1) == stage:
                            continue
                        if m.group(1) not in allowed[stage]:
                            problems.append(f'{path}:{number}: stage {stage} includes '
                                            f'{m.group(1)}/{m.group(2)} ({stage} builds on: '
                                            f'{", ".join(sorted(allowed[stage])) or "nothing"})')
    return problems


def nm_symbols(library):
    out = subprocess.run(['nm', '--format=posix', library], check=True, capture_output=True,
                         text=True).stdout
    defined, undefined = set(), set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) < 2 or line.endswith(':'):
            continue
        name, kind = parts[0], parts[1]
        if kind in 'Uw':
            undefined.add(name)
        elif kind in 'TtWVDdBbRrGgSsi' or kind == 'u':
            defined.add(name)
    return defined, undefined - defined


def demangle(name):
    try:
        return subprocess.run(['c++filt', name], check=True, capture_output=True,
                              text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return name


def check_symbols(source_dir, libraries):
    stages, allowed = stage_graph(source_dir)
    found = {}
    for item in libraries:
        candidates = [os.path.join(item, f) for f in os.listdir(item)] if os.path.isdir(item) else [item]
        for path in candidates:
            m = re.search(r'liblocard_([a-z_]+)\.a$', path)
            if m and m.group(1) in stages:
                found[m.group(1)] = path
    missing = [s for s in stages if s not in found]
    if missing:
        return [f'stage libraries not found: {", ".join("liblocard_" + s + ".a" for s in missing)}']
    symbols = {s: nm_symbols(found[s]) for s in stages}
    definers = collections.defaultdict(set)
    for stage, (defined, _) in symbols.items():
        for name in defined:
            definers[name].add(stage)
    problems = []
    for stage in stages:
        for name in sorted(symbols[stage][1]):
            where = definers.get(name)
            if not where or where & (allowed[stage] | {stage}):
                continue  # a system library's, or one the stage may use
            problems.append(f'liblocard_{stage}.a needs {demangle(name)}, defined only in '
                            f'{", ".join(sorted(where))} (not a stage {stage} builds on)')
    return problems


def strip_code(text):
    """Comments, string and character literals and preprocessor lines blanked, newlines kept."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == '#':
            j = i
            while j < n and text[j] != '\n':  # a directive, continued lines included
                j += 2 if text[j] == '\\' and j + 1 < n else 1
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
            continue
        if c == '\n':
            at_line_start = True
            out.append(c)
            i += 1
            continue
        if not c.isspace():
            at_line_start = False
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            out.append(' ' * (j - i))
            i = j
        elif text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c == 'R' and text.startswith('R"', i):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            end = text.find(')' + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c in '"\'':
            if c == "'" and i > 0 and text[i - 1].isalnum():  # a digit separator: 1'000
                out.append(' ')
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != '\n':
                j += 2 if text[j] == '\\' else 1
            out.append(c + ' ' * (min(j, n) - i - 1) + (c if j < n else ''))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return ''.join(out)


SCOPE = re.compile(r'\b(namespace|class|struct|union|enum)\b')


def function_lengths(path):
    """(name, first line, length in lines) of every function body in a C++ file."""
    text = strip_code(open(path, errors='replace').read())
    results = []
    stack = []  # per open brace: 'scope', 'function' (start line, name) or 'other'
    head_start = 0  # where the text before the next brace begins (after ; { or })
    line = 1
    line_at = [0] * (len(text) + 1)
    for i, c in enumerate(text):
        line_at[i] = line
        if c == '\n':
            line += 1
    functions_open = 0  # function kinds on the stack
    for i, c in enumerate(text):
        inside_function = functions_open > 0
        if c == '{':
            if inside_function:
                stack.append(('other',))
            else:
                head = text[head_start:i]
                words = head.strip()
                paren = words.find('(')
                before_paren = words if paren < 0 else words[:paren]
                if SCOPE.search(before_paren) and not before_paren.rstrip().endswith(('=', ']')):
                    stack.append(('scope',))
                elif paren >= 0 and not re.search(r'=\s*$', words):
                    m = re.search(r'([~\w:<>,\s*&]+?)\s*\(', words)
                    name = m.group(1).split()[-1] if m and m.group(1).split() else '?'
                    start = head_start + (len(head) - len(head.lstrip()))
                    stack.append(('function', line_at[start], name))
                    functions_open += 1
                else:
                    stack.append(('other',))
            head_start = i + 1
        elif c == '}':
            if stack:
                kind = stack.pop()
                if kind[0] == 'function':
                    functions_open -= 1
                    results.append((kind[2], kind[1], line_at[i] - kind[1] + 1))
            head_start = i + 1
        elif c == ';' and not inside_function:
            head_start = i + 1
    return results


def check_functions(source_dir, limit):
    problems = []
    for top in ('src', 'apps'):
        for folder, _, files in os.walk(os.path.join(source_dir, top)):
            for name in sorted(files):
                if not name.endswith(('.cpp', '.hpp', '.h', '.cc')):
                    continue
                path = os.path.join(folder, name)
                for function, first, length in function_lengths(path):
                    if length > limit:
                        problems.append(f'{os.path.relpath(path, source_dir)}:{first}: '
                                        f'{function} is {length} lines (limit {limit})')
    return problems


SELFTEST_CMAKE = """set(LOCARD_STAGES low mid high
    CACHE INTERNAL "stages")
set(locard_low_stages)
set(locard_mid_stages low)
set(locard_high_stages mid)
"""


def selftest():
    import tempfile
    failures = []

    def expect(what, problems, count):
        if len(problems) != count:
            failures.append(f'{what}: expected {count} problem(s), got {problems}')

    with tempfile.TemporaryDirectory() as root:
        def write(path, text):
            os.makedirs(os.path.dirname(os.path.join(root, path)), exist_ok=True)
            with open(os.path.join(root, path), 'w') as f:
                f.write(text)
        write('src/CMakeLists.txt', SELFTEST_CMAKE)
        write('src/high/h.cpp', '#include <locard/low/a.hpp>\n#include "mid/b.hpp"\n')
        write('src/mid/m.cpp', '#include <locard/low/a.hpp>\n')
        write('src/low/l_test.cpp', '#include <locard/high/c.hpp>\n')  # tests may
        expect('includes, clean', check_includes(root), 0)
        write('src/low/l.cpp', '// #include <locard/high/c.hpp> in a comment is fine\n'
                               '#include <locard/mid/b.hpp>\n')
        write('include/locard/mid/b.hpp', '#include <locard/high/c.hpp>\n')
        expect('includes, two back-edges', check_includes(root), 2)

        body = '\n'.join('  x += %d;' % k for k in range(150))
        write('src/low/f.cpp', 'namespace n {\nstruct S {\n  int g() const {\n' + body +
              '\n  }\n};\n}\n')
        expect('functions, 152 lines in a class', check_functions(root, 150), 1)
        write('src/low/f.cpp', 'int f() {\n  auto s = "{{{";\n  char c = \'}\';\n'
              '  auto l = [] { return 1; };\n  // }\n  return l() + s[0] + c;\n}\n'
              'int g() { return 1; }\n')
        lengths = sorted(function_lengths(os.path.join(root, 'src/low/f.cpp')))
        if lengths != [('f', 1, 7), ('g', 8, 1)]:
            failures.append(f'functions: braces in strings, comments and lambdas: {lengths}')
    for f in failures:
        print('selftest:', f)
    return failures


def main(argv):
    if len(argv) == 2 and argv[1] == 'selftest':
        failures = selftest()
        print(f'check_architecture selftest: {len(failures)} failure(s)')
        return 1 if failures else 0
    if len(argv) < 3 or argv[1] not in ('includes', 'symbols', 'functions'):
        print(__doc__, file=sys.stderr)
        return 2
    source_dir = argv[2]
    if argv[1] == 'includes':
        problems = check_includes(source_dir)
    elif argv[1] == 'symbols':
        problems = check_symbols(source_dir, argv[3:])
    else:
        limit = int(argv[argv.index('--limit') + 1]) if '--limit' in argv else 150
        problems = check_functions(source_dir, limit)
    for p in problems:
        print(p)
    print(f'check_architecture {argv[1]}: {len(problems)} problem(s)')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
