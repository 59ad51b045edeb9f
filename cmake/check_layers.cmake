# Keeps the library's floors apart: run by the build before lrf_lib compiles (and by a test on a planted
# violation). Each folder of src/lrf/ sits on a floor, in an order within it; a file may include headers
# of its own folder, of folders earlier on its floor, and of lower floors, never of a later folder or a
# higher floor. So the include graph has no edge running back up and no cycle between folders.
#
#   cmake -DSOURCE_ROOT=<dir holding lrf/> [-DSTAMP=<file written when clean>] -P check_layers.cmake
#
# A new folder must be given its place here: an unlisted folder is an error too.

set(LRF_FLOORS
  "core"
  "scene,autoencoder/conv,autoencoder,eval,optim,distributed,presets"
  "splat/raster,splat,splat/train,align,points,splat/run,camera_path"
  "feature,rgb,latent,nerf,refine,finetune"
  "frames,field_kinds,detail,video,viewer,compare,pipeline,demo")
set(LRF_FLOOR_NAMES
  "core"
  "data and models: scenes, autoencoders, metrics, optimisers, data parallelism"
  "Gaussians and geometry: rasteriser, trainer, run folders, initial points, correspondences, camera paths"
  "field kinds and the paper's stages: RGB, latent, feature and NeRF fields, refinement, Stage I and III"
  "what users run: frames, field kinds, detail pass, video, viewer, compare, pipeline, demo")

if(NOT SOURCE_ROOT)
  message(FATAL_ERROR "check_layers.cmake: pass -DSOURCE_ROOT=<folder holding lrf/>")
endif()

# Rank of every folder: floor * 100 + position on the floor (a floor's folders are comma-separated, since
# CMake would flatten a ;-list inside a list).
set(floor 0)
foreach(folders IN LISTS LRF_FLOORS)
  string(REPLACE "," ";" folders "${folders}")
  set(position 0)
  foreach(folder IN LISTS folders)
    math(EXPR rank "${floor} * 100 + ${position}")
    set(rank_of_${folder} ${rank})
    set(floor_of_${folder} ${floor})
    math(EXPR position "${position} + 1")
  endforeach()
  math(EXPR floor "${floor} + 1")
endforeach()

function(folder_of path out)
  # lrf/splat/run/x.h -> splat/run ; lrf/core/x.h -> core
  string(REGEX REPLACE "^lrf/" "" rel "${path}")
  get_filename_component(dir "${rel}" DIRECTORY)
  set(${out} "${dir}" PARENT_SCOPE)
endfunction()

file(GLOB_RECURSE files RELATIVE "${SOURCE_ROOT}" "${SOURCE_ROOT}/lrf/*.h" "${SOURCE_ROOT}/lrf/*.cpp"
     "${SOURCE_ROOT}/lrf/*.inc")
list(SORT files)
set(problems "")
foreach(file IN LISTS files)
  folder_of("${file}" own)
  if(NOT DEFINED rank_of_${own})
    string(APPEND problems "\n  ${file}: its folder '${own}' has no floor in cmake/check_layers.cmake")
    continue()
  endif()
  file(STRINGS "${SOURCE_ROOT}/${file}" includes REGEX "^[ \t]*#[ \t]*include[ \t]*\"lrf/")
  foreach(line IN LISTS includes)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]+)\".*" "\\1" header "${line}")
    folder_of("${header}" target)
    if(target STREQUAL own OR NOT EXISTS "${SOURCE_ROOT}/${header}")
      continue()  # generated headers (build_info.h) and the folder's own
    endif()
    if(NOT DEFINED rank_of_${target})
      string(APPEND problems "\n  ${file} includes ${header}: folder '${target}' has no floor")
    elseif(rank_of_${target} GREATER rank_of_${own})
      list(GET LRF_FLOOR_NAMES ${floor_of_${own}} own_name)
      list(GET LRF_FLOOR_NAMES ${floor_of_${target}} target_name)
      if(floor_of_${target} GREATER floor_of_${own})
        set(why "a higher floor (${target_name}) than ${own}'s (${own_name})")
      else()
        set(why "the same floor as ${own} (${own_name}) but after it; the order on a floor keeps its folders free of cycles")
      endif()
      string(APPEND problems "\n  ${file} includes ${header}: ${target} is on ${why}")
    endif()
  endforeach()
endforeach()

if(problems)
  message(FATAL_ERROR "includes against the library's floors (cmake/check_layers.cmake):${problems}\n"
                      "Move the code to the floor it belongs to, or pass what it needs down as a parameter.")
endif()
if(STAMP)
  file(WRITE "${STAMP}" "layers checked\n")
endif()
