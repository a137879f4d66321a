#!/usr/bin/env bash
# The viewer's tests (make test-web): type check and unit tests (vitest, Node.js), then the
# browser tests (tests/web/browser: headless Chromium driven by playwright-core).
#
# What is missing is installed, and said so: the npm packages (in web/) and Debian's
# Chromium (apt-get; never a browser downloaded by a test tool). Under CI (CI=true) every test
# must run: anything that cannot be installed is a failure. Elsewhere, tests that cannot run
# are skipped with a message that says which and why.
#   tests/web/run.sh             install what is missing, run everything
#   tests/web/run.sh --deps-only install what is missing (make web-deps)
set -uo pipefail
cd "$(dirname "$0")/../.."
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
DEPS_ONLY=${1:-}

skip() { # skip WHAT WHY
  echo "test-web: SKIPPED $1: $2"
  if [ "${CI:-}" = "true" ]; then
    echo "test-web: CI=true: the browser tests must run, so this is a failure"
    exit 1
  fi
  exit 0
}

if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  skip "the viewer's tests" "Node.js and npm are not installed (https://nodejs.org, or apt-get install nodejs npm)"
fi
if [ ! -x web/node_modules/.bin/vitest ] || [ ! -x web/node_modules/.bin/tsc ] \
   || [ web/package-lock.json -nt web/node_modules/.package-lock.json ]; then
  # `npm install` at the versions of the lockfile (which it leaves as it is): npm 11's `npm ci`
  # refuses lockfiles that, as npm 11 writes them, leave out other platforms' optional packages.
  echo "test-web: installing the viewer's npm packages (npm install in web/, from package-lock.json)"
  (cd web && npm install --no-audit --no-fund --loglevel=error) || skip "the viewer's tests" "npm install failed"
fi
if [ ! -x "$CHROMIUM" ]; then
  echo "test-web: installing Chromium (Debian's chromium package, about 30 s)"
  if [ "$(id -u)" = 0 ]; then SUDO=(); elif sudo -n true 2>/dev/null; then SUDO=(sudo -n); else SUDO=(none); fi
  if [ "${SUDO[0]:-}" != none ]; then
    "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -qq \
      && "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  fi
  if [ ! -x "$CHROMIUM" ]; then
    NO_BROWSER="Chromium is not at $CHROMIUM and apt-get could not install it"
    [ "${SUDO[0]:-}" = none ] && NO_BROWSER="$NO_BROWSER (apt-get needs root: sudo apt-get install chromium)"
  fi
fi
[ "$DEPS_ONLY" = "--deps-only" ] && { [ -z "${NO_BROWSER:-}" ] || skip "Chromium" "$NO_BROWSER"; exit 0; }

echo "test-web: type check and unit tests (web/test)"
(cd web && ./node_modules/.bin/tsc --noEmit && ./node_modules/.bin/vitest run --reporter=dot) || exit 1
[ -z "${NO_BROWSER:-}" ] || skip "the browser tests (tests/web/browser)" "$NO_BROWSER"
echo "test-web: browser tests (tests/web/browser, headless $("$CHROMIUM" --version 2>/dev/null | head -1))"
cd web && exec ./node_modules/.bin/vitest run --root ../tests/web/browser
