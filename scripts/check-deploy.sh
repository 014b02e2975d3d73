#!/usr/bin/env bash
# Validates deploy/: every Kubernetes manifest against the Kubernetes API schemas
# (kubernetes-validate, strict: unknown fields are errors; the oldest supported version,
# 1.29, and the newest the tool knows) and the compose file against the Compose
# Specification's schema (check-jsonschema's vendored compose-spec). The tools come
# from PyPI into a virtual environment under target/; without python3 or PyPI the
# check says so and is skipped, unless CI=true, where that is an error.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/deploy-venv
fail_or_skip() {
  if [ "${CI:-}" = true ]; then
    echo "error: $1" >&2
    exit 1
  fi
  echo "warning: $1; deploy/ not validated" >&2
  exit 0
}
if [ ! -x "$venv/bin/kubernetes-validate" ] || [ ! -x "$venv/bin/check-jsonschema" ]; then
  command -v python3 >/dev/null 2>&1 || fail_or_skip "python3 not found"
  python3 -m venv "$venv" >/dev/null 2>&1 || {
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
      (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null) || true
    fi
    python3 -m venv "$venv" >/dev/null 2>&1 || fail_or_skip "cannot create a Python virtual environment (apt-get install python3-venv)"
  }
  "$venv/bin/pip" install -q --disable-pip-version-check kubernetes-validate==1.37.0 check-jsonschema >/dev/null 2>&1 ||
    fail_or_skip "cannot install kubernetes-validate and check-jsonschema from PyPI"
fi
for manifest in deploy/*.yaml; do
  case "$manifest" in
    deploy/compose.yaml) "$venv/bin/check-jsonschema" --builtin-schema vendor.compose-spec "$manifest" ;;
    *)
      for k in 1.29.0 1.37.0; do
        "$venv/bin/kubernetes-validate" --strict --quiet -k "$k" "$manifest"
      done
      echo "ok -- $manifest valid for Kubernetes 1.29 and 1.37"
      ;;
  esac
done
