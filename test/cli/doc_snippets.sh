#!/bin/bash
# The docs show files as they are: README's demo graph is graphs/demo.xml, the
# guide's whole plugin is test/test_plugins/threshold.cpp, and the guide's
# out-of-tree plugin is examples/hello_plugin.cpp. Usage: doc_snippets.sh SOURCE_DIR
src=$1
status=0
# The fenced block of a markdown file that starts with the line FIRST.
block() { awk -v first="$2" '$0 == first { on = 1 } on && /^```$/ { exit } on { print }' "$1"; }
check() {  # doc, first line of the block, the file it shows (from that line on)
  local shown
  shown=$(block "$src/$1" "$2")
  if [ -n "$shown" ] && diff -u <(awk -v first="$2" '$0 == first { on = 1 } on' "$src/$3") <(echo "$shown"); then
    echo "same: $1 and $3"
  else
    echo "differ: $1 and $3"
    status=1
  fi
}
# The demo graph from its <graph> line on: the file's heading comment is not repeated.
check README.md '<graph name="demo">' graphs/demo.xml
check docs/guide.md "// The guide's example (docs/guide.md): a whole plugin, one input, one output, two parameters." \
  test/test_plugins/threshold.cpp
check docs/guide.md "// An out-of-tree plugin: one node, hello.invert, that turns an 8-bit image into" \
  examples/hello_plugin.cpp
exit $status
