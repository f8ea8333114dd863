# One static library per pipeline stage (hazmap::<stage>, libhazmap_<stage>.a, a .so in a
# HAZMAP_SANITIZE build (root CMakeLists.txt): every src/<stage>/*.cpp, globbed, so new files
# need no edit here), linked along the documented data
# flow (DEVELOPERS.md "Layout"; scripts/check-layers.sh checks the same arrows file by file):
#
#   core < io < sources < properties < preprocess < registration < odometry < loop < graph < map
#        < eval < pipeline < demo,         sim beside: uses core..preprocess, used only by demo
#
# The build enforces the arrows: each stage compiles against an include tree of its own
# (<build>/stage-include/<stage>: symbolic links to include/hazmap/<stage> and src/<stage> of the
# stage itself and of the stages it may use, nothing else), so an include pointing up the flow is
# a compile error ("No such file"), and the link graph has no cycle (static libraries link in
# order). `hazmap` (hazmap::hazmap) stays the umbrella: an interface target with every stage and
# the whole include/ tree, for apps/, tests/, bench/, python/, fuzz/ and find_package(hazmap).

# The stages in an order where each uses only stages before it (the link order).
set(HAZMAP_STAGES core io sources preprocess properties registration odometry loop graph map eval
  pipeline sim demo)
# What each stage may use (its own folder is always visible).
set(HAZMAP_STAGE_USES_core)
set(HAZMAP_STAGE_USES_io core)
set(HAZMAP_STAGE_USES_sources core io)
# preprocess stands after properties in the flow, but properties uses preprocess's normals (the
# documented exception below), so this one arrow points the other way: preprocess does not see
# properties, and the two libraries do not link each other both ways.
set(HAZMAP_STAGE_USES_preprocess core io sources)
set(HAZMAP_STAGE_USES_properties core io sources)
set(HAZMAP_STAGE_USES_registration core io sources properties preprocess)
set(HAZMAP_STAGE_USES_odometry ${HAZMAP_STAGE_USES_registration} registration)
set(HAZMAP_STAGE_USES_loop ${HAZMAP_STAGE_USES_odometry} odometry)
set(HAZMAP_STAGE_USES_graph ${HAZMAP_STAGE_USES_loop} loop)
set(HAZMAP_STAGE_USES_map ${HAZMAP_STAGE_USES_graph} graph)
set(HAZMAP_STAGE_USES_eval ${HAZMAP_STAGE_USES_map} map)
set(HAZMAP_STAGE_USES_pipeline ${HAZMAP_STAGE_USES_eval} eval)
set(HAZMAP_STAGE_USES_sim core io sources properties preprocess)
set(HAZMAP_STAGE_USES_demo ${HAZMAP_STAGE_USES_pipeline} pipeline sim)
# The documented exception (scripts/check-layers.sh): properties uses preprocess's normals, shared
# low-level geometry (PCA over neighbours, with the spatial index it searches), for the rules'
# normal_z variable on the raw scan. It sees those two headers and links preprocess.
set(HAZMAP_STAGE_HEADERS_properties preprocess/normals.hpp preprocess/spatial_index.hpp)
set(HAZMAP_STAGE_LINKS_properties preprocess)

# Third-party libraries: private to the stages (a static library passes them on as link-only).
set(HAZMAP_STAGE_THIRD_PARTY TBB::tbb Ceres::ceres yaml-cpp fmt::fmt spdlog::spdlog embree nanoflann::nanoflann
  nlohmann_json::nlohmann_json ${STB_LIBRARY} ${CAIRO_LIBRARY} SQLite::SQLite3 PkgConfig::ZSTD
  PkgConfig::LZ4 PkgConfig::GST BZip2::BZip2 ZLIB::ZLIB ${PCAP_LIBRARY} ${CIVETWEB_LIBRARY})

# A symbolic link `link` -> `target`, replacing whatever `link` was.
function(hazmap_stage_link target link)
  if(IS_SYMLINK ${link})
    file(READ_SYMLINK ${link} current)
    if(current STREQUAL target)
      return()
    endif()
    file(REMOVE ${link})  # the link only, never what it points to
  elseif(IS_DIRECTORY ${link})
    file(REMOVE_RECURSE ${link})  # an exception's folder of header links, now linked whole
  endif()
  get_filename_component(dir ${link} DIRECTORY)
  file(MAKE_DIRECTORY ${dir})
  file(CREATE_LINK ${target} ${link} SYMBOLIC)
endfunction()

# <build>/stage-include/<stage>/{include/hazmap,src}/<stage it may see> -> the real folders. Links
# to stages no longer visible are removed (links only: file(REMOVE) does not follow them).
function(hazmap_stage_tree stage out)
  set(tree ${CMAKE_CURRENT_BINARY_DIR}/stage-include/${stage})
  set(visible ${stage} ${HAZMAP_STAGE_USES_${stage}})
  foreach(sub include/hazmap src)
    file(GLOB entries LIST_DIRECTORIES true ${tree}/${sub}/*)
    foreach(entry ${entries})
      get_filename_component(name ${entry} NAME)
      if(IS_SYMLINK ${entry} AND NOT name IN_LIST visible)
        file(REMOVE ${entry})
      endif()
    endforeach()
    foreach(used ${visible})
      if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${sub}/${used})
        hazmap_stage_link(${CMAKE_CURRENT_SOURCE_DIR}/${sub}/${used} ${tree}/${sub}/${used})
      endif()
    endforeach()
  endforeach()
  foreach(header ${HAZMAP_STAGE_HEADERS_${stage}})
    hazmap_stage_link(${CMAKE_CURRENT_SOURCE_DIR}/include/hazmap/${header} ${tree}/include/hazmap/${header})
  endforeach()
  set(${out} ${tree} PARENT_SCOPE)
endfunction()

# Every folder of src/ is a stage listed above (a new folder needs its place in the flow first).
file(GLOB HAZMAP_SRC_FOLDERS LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}/src
  ${CMAKE_CURRENT_SOURCE_DIR}/src/*)
foreach(folder ${HAZMAP_SRC_FOLDERS})
  if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/src/${folder} AND NOT folder IN_LIST HAZMAP_STAGES)
    message(FATAL_ERROR "src/${folder} is not a stage of cmake/stages.cmake: add it to HAZMAP_STAGES "
                        "with what it may use (and to scripts/check-layers.sh, DEVELOPERS.md)")
  endif()
endforeach()

# Shared stages (sanitizer builds): installed binaries find them in the prefix's library folder.
if(HAZMAP_STAGE_LIBRARY_TYPE STREQUAL "SHARED")
  set(CMAKE_INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")
endif()
add_library(hazmap INTERFACE)
add_library(hazmap::hazmap ALIAS hazmap)
target_include_directories(hazmap INTERFACE
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
set(HAZMAP_STAGE_TARGETS)
foreach(stage ${HAZMAP_STAGES})
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/${stage}/*.cpp)
  add_library(hazmap_${stage} ${HAZMAP_STAGE_LIBRARY_TYPE} ${sources})
  add_library(hazmap::${stage} ALIAS hazmap_${stage})
  # No <target>_EXPORTS macro for shared stages (sanitizer builds; nothing reads it): with it every
  # stage compiles with its own definition and cannot reuse the stages' one PCH (-Winvalid-pch).
  set_target_properties(hazmap_${stage} PROPERTIES EXPORT_NAME ${stage} DEFINE_SYMBOL "")
  hazmap_stage_tree(${stage} tree)
  target_include_directories(hazmap_${stage}
    PUBLIC $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${tree}/include ${tree}/src ${STB_INCLUDE_DIR} ${CAIRO_INCLUDE_DIR} ${PCAP_INCLUDE_DIR} ${CIVETWEB_INCLUDE_DIR})
  set(links)
  foreach(used ${HAZMAP_STAGE_USES_${stage}} ${HAZMAP_STAGE_LINKS_${stage}})
    list(APPEND links hazmap_${used})
  endforeach()
  target_link_libraries(hazmap_${stage} PUBLIC Eigen3::Eigen ${links} PRIVATE ${HAZMAP_STAGE_THIRD_PARTY})
  target_compile_options(hazmap_${stage} PRIVATE -Wall -Wextra -Wno-restrict)
  target_compile_definitions(hazmap_${stage} PRIVATE
    HAZMAP_DATA_INSTALL_DIR="${CMAKE_INSTALL_FULL_DATADIR}/hazmap")
  target_link_libraries(hazmap INTERFACE hazmap_${stage})
  list(APPEND HAZMAP_STAGE_TARGETS hazmap_${stage})
endforeach()
