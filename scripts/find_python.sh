#!/bin/sh
# Print the path of a Python X.Y interpreter (argument: 3.13 or 3.11): pythonX.Y on PATH if it runs, else
# the newest pyenv install of X.Y. Blender 5.2 LTS and 5.3 need Python 3.13; Blender 4.5 LTS needs 3.11.
want="$1"
if command -v "python$want" >/dev/null 2>&1 && "python$want" -c "" >/dev/null 2>&1; then
    command -v "python$want"; exit 0
fi
root="$(pyenv root 2>/dev/null || echo "$HOME/.pyenv")"
found="$(ls -d "$root"/versions/"$want".*/bin/"python$want" 2>/dev/null | sort -V | tail -n 1)"
if [ -n "$found" ]; then echo "$found"; exit 0; fi
echo "python$want-not-found"
echo "find_python: no Python $want: install it (pyenv install $want, or your system's python$want package)" >&2
exit 1
