#!/usr/bin/env bash
# The package's include rules, checked on every include line of src/core,
# include/magnetometer_insitu_calibration (but its ros/ folder), src/cli, src/tools and
# src/program_support (a ctest entry, core_layering).
#
# 1. The core, by concern (src/core/<concern>/ and include/magnetometer_insitu_calibration/<concern>/
#    with their subfolders): the package headers ("magnetometer_insitu_calibration/<c>/...") a
#    concern may include:
#      concern        may include (besides itself)
#      common         nothing of the package
#      formats        common                      (record formats never include estimation)
#      instrument     common, formats
#      preprocessing  common
#      estimation     common                      (estimation never includes formats)
#      simulation     common, preprocessing, estimation
#      pipeline       common, preprocessing, estimation
#    and no core file includes ROS (<ros/...>, <sensor_msgs/...>, the package's ros/ headers).
# 2. Private headers. A quoted include without the package prefix ("name.hpp", "../name.hpp")
#    names a file relative to the including file's folder, where the compiler looks first. A
#    private header may be included from its own folder and from that folder's subfolders
#    (estimation's spectral_tools.hpp serves estimation/robust/ as "../spectral_tools.hpp"),
#    never from a parent or a sibling folder: a subfolder's private header is included only
#    within that subfolder (estimation/robust/section_irls.hpp is not estimation's), and no
#    concern includes another's (what it needs gets a public header). A public header includes
#    no private header.
# 3. The programs. src/cli and src/tools may include the core, src/program_support and their own
#    folder; neither includes the other. src/program_support may include the core and its own
#    folder. src/tools and src/program_support (the bag tools) may also include the ROS layer's
#    public headers (magnetometer_insitu_calibration/ros/...); src/cli neither those nor ROS
#    itself: its programs reach bags through src/program_support. A quoted name that is not
#    beside the including file is taken from src/program_support, the programs' include path
#    (CMakeLists.txt, src/tools/tools.cmake), or else from wherever in src/ it is.
#    src/ros (the nodes) is not checked.
# Prints each violation as file:line: reason and exits 1 if there is any.
set -u
root="$(cd "${1:-$(dirname "$0")/..}" && pwd -P)"
package=magnetometer_insitu_calibration
declare -A allowed=(
  [common]="common"
  [formats]="common formats"
  [instrument]="common formats instrument"
  [preprocessing]="common preprocessing"
  [estimation]="common estimation"
  [simulation]="common preprocessing estimation simulation"
  [pipeline]="common preprocessing estimation pipeline"
)
core_concerns=" ${!allowed[*]} "
ros_include='<(ros|rosbag|sensor_msgs|std_msgs|diagnostic_updater|nodelet)/'
violations=0
checked=0

violation() {  # file line reason
  echo "${1#"$root"/}:$2: $3"
  violations=$((violations + 1))
}

include_lines() {  # folder: "file:line:text" of its include lines, subfolders included
  grep -rn '^[[:space:]]*#[[:space:]]*include' "$1" --include='*.cpp' --include='*.hpp'
}

beside() {  # file name: the folder of the header `name` relative to file's folder; empty if none
  local path
  path="$(realpath -m "$(dirname "$1")/$2")"
  if [ -f "$path" ]; then dirname "$path"; fi
}

visible_from() {  # header_folder file_folder top: header_folder is file_folder or a parent of it below top
  [[ "$2/" == "$1/"* && "$1/" == "$3/"* ]]
}

# 1 and 2: the core.
for concern in "${!allowed[@]}"; do
  for top in "$root/src/core/$concern" "$root/include/$package/$concern"; do
    [ -d "$top" ] || { echo "missing folder: $top"; violations=$((violations + 1)); continue; }
    while IFS= read -r hit; do
      file=${hit%%:*}; rest=${hit#*:}; line=${rest%%:*}; text=${rest#*:}
      checked=$((checked + 1))
      if [[ "$text" =~ $ros_include ]] || [[ "$text" =~ $package/ros/ ]]; then
        violation "$file" "$line" "ROS include in the ROS-free core: $text"; continue
      fi
      if [[ "$text" =~ \"$package/([a-z_]+)/ ]]; then
        target=${BASH_REMATCH[1]}
        if [[ " ${allowed[$concern]} " != *" $target "* ]]; then
          violation "$file" "$line" "$concern may not include $target: $text"
        fi
      elif [[ "$text" =~ \"$package/[a-z_0-9]+\.hpp\" ]]; then
        violation "$file" "$line" "header outside the concern folders: $text"
      elif [[ "$text" =~ \"([^\"]+)\" ]]; then
        name=${BASH_REMATCH[1]}
        folder="$(beside "$file" "$name")"
        if [ -z "$folder" ]; then
          violation "$file" "$line" "private header not found beside the including file: $text"
        elif [[ "$top" == "$root/include/"* && "$folder/" != "$root/include/"* ]]; then
          violation "$file" "$line" "a public header includes the private ${folder#"$root"/}/${name##*/}: $text"
        elif ! visible_from "$folder" "$(dirname "$file")" "$top"; then
          violation "$file" "$line" "private header of ${folder#"$root"/}/ outside its folder: $text"
        fi
      fi
    done < <(include_lines "$top")
  done
done

# 3: the programs.
for program_dir in src/cli src/tools src/program_support; do
  own="$root/$program_dir"
  [ -d "$own" ] || { echo "missing folder: $own"; violations=$((violations + 1)); continue; }
  may_use_ros=1
  [ "$program_dir" = src/cli ] && may_use_ros=0
  while IFS= read -r hit; do
    file=${hit%%:*}; rest=${hit#*:}; line=${rest%%:*}; text=${rest#*:}
    checked=$((checked + 1))
    if [[ "$text" =~ $ros_include ]]; then
      [ "$may_use_ros" -eq 1 ] || violation "$file" "$line" "$program_dir includes ROS (bags: src/program_support): $text"
      continue
    fi
    [[ "$text" =~ \"([^\"]+)\" ]] || continue  # <...>: a library's header
    name=${BASH_REMATCH[1]}
    if [[ "$name" == "$package"/*/* ]]; then  # a public header of the package
      target=${name#"$package"/}; target=${target%%/*}
      if [[ "$core_concerns" == *" $target "* ]] || [[ "$target" == ros && "$may_use_ros" -eq 1 ]]; then continue; fi
      violation "$file" "$line" "$program_dir may not include the package's $target/: $text"; continue
    fi
    if [[ "$name" == "$package"/* ]]; then  # the package's generated message headers
      [ "$may_use_ros" -eq 1 ] || violation "$file" "$line" "$program_dir includes ROS (bags: src/program_support): $text"
      continue
    fi
    folder="$(beside "$file" "$name")"
    if [ -z "$folder" ]; then
      for candidate in src/program_support src/cli src/tools src/ros src/core; do
        found="$(find "$root/$candidate" -path "*/$name" -type f -print -quit 2>/dev/null)"
        if [ -n "$found" ]; then folder="$(dirname "$found")"; break; fi
      done
    fi
    if [ -z "$folder" ]; then
      violation "$file" "$line" "header found neither beside the including file nor in src/: $text"
    elif [[ "$folder/" != "$own/"* && "$folder" != "$root/src/program_support" ]]; then
      violation "$file" "$line" "$program_dir may not include ${folder#"$root"/}/${name##*/}: $text"
    fi
  done < <(include_lines "$own")
done

echo "check_layering: $checked include lines checked, $violations violations"
[ "$checked" -gt 0 ] && [ "$violations" -eq 0 ]
