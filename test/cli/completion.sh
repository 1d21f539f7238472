#!/bin/bash
# The bash completion script `saccade completion bash` makes, driven as bash
# drives it. Usage: completion.sh SACCADE
saccade=$1
source <("$saccade" completion bash) || exit 1
complete_words() {
  COMP_WORDS=("$@")
  COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
  _saccade
  echo "${COMPREPLY[*]}"
}
echo "registered: $(complete -p saccade)"
echo "subcommand: $(complete_words "$saccade" ru)"
echo "run option: $(complete_words "$saccade" run g.xml --fra)"
echo "global option after the subcommand: $(complete_words "$saccade" run g.xml --plugin-p)"
echo "log levels: $(complete_words "$saccade" --log-level wa)"
echo "plugin types: $(complete_words "$saccade" plugins capture.vi)"
