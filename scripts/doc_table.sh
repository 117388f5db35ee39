# Sourced by the scripts that measure a document's tables (cores.sh, firmware_doc.sh).
# doc_table TABLE DOC CHECK WHAT: with CHECK 0 prints TABLE; with 1 exits 0 only if every
# non-empty line of TABLE is a whole line of DOC, naming each line that is not (WHAT: what
# the tables are, for the message).
doc_table() {
  local table=$1 doc=$2 check=$3 what=$4 stale=0 l
  if [ "$check" = 0 ]; then
    cat "$table"
    exit 0
  fi
  while IFS= read -r l; do
    [ -n "$l" ] || continue
    grep -qxF -- "$l" "$doc" || { echo "$doc is stale: it should hold '$l'" >&2; stale=1; }
  done < "$table"
  [ $stale = 0 ] && echo "$(basename "$0"): $doc's $what as measured"
  exit $stale
}
