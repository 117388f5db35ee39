#!/usr/bin/env bash
# Fetches the scene suite's scenes (experiments/scenes.tsv) into SCENES/NAME/, each from its
# repository at its pinned commit. Needs git and network access to the repositories (or
# local copies: SCENE_GIT_URL='/mirrors/{owner}+{name}/repo' instead of GitHub's address).
#   experiments/fetch_scenes.sh SCENES [NAME ...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dest=${1:?usage: fetch_scenes.sh SCENES [NAME ...]}
shift
github='https://github.com/{owner}/{name}.git'
url_tpl=${SCENE_GIT_URL:-$github}
mkdir -p "$dest/.git-cache"
while IFS=$'\t' read -r name kind repo commit paths prep _licence; do
  case "$name" in ''|\#*) continue ;; esac
  if [ $# -gt 0 ] && ! printf '%s\n' "$@" | grep -qx "$name"; then continue; fi
  if [ -e "$dest/$name" ]; then echo "$name: $dest/$name exists, kept"; continue; fi
  owner=${repo%%/*} rname=${repo#*/}
  url=${url_tpl//\{owner\}/$owner}
  url=${url//\{name\}/$rname}
  git_dir=$dest/.git-cache/$owner+$rname
  if [ ! -d "$git_dir" ]; then
    git clone --quiet --bare --filter=blob:none "$url" "$git_dir" 2>/dev/null ||
      git clone --quiet --bare "$url" "$git_dir"
  fi
  tmp=$(mktemp -d)
  # Every path of the scene, expanded against the commit's tree (globs allowed).
  list=$(git --git-dir="$git_dir" ls-tree -r --name-only "$commit")
  mkdir -p "$tmp/$name"
  for p in $paths; do
    base=${p%/.}
    matched=0
    while IFS= read -r f; do
      [ -n "$f" ] || continue
      case "$f" in $base|$base/*) ;; *) continue ;; esac
      matched=1
      if [ "$p" != "$base" ]; then rel=${f#$base/}; else rel=${f#$(dirname "$base")/}; fi
      [ "$(dirname "$base")" = . ] && [ "$p" = "$base" ] && rel=$f
      mkdir -p "$tmp/$name/$(dirname "$rel")"
      git --git-dir="$git_dir" show "$commit:$f" > "$tmp/$name/$rel"
    done <<<"$list"
    [ $matched = 1 ] || { echo "$name: $p is not in $repo at $commit" >&2; rm -rf "$tmp"; exit 1; }
  done
  case "$prep" in
    link\ *) set -f; read -r _ a b <<<"$prep"; set +f; ln -s "$b" "$tmp/$name/$a" ;;
  esac
  mv "$tmp/$name" "$dest/$name"
  rm -rf "$tmp"
  echo "$name: $repo at ${commit:0:7} into $dest/$name"
done < "$here/scenes.tsv"
