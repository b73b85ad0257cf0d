# sigmaheart_library(<name> SOURCES <files...> [UNITY_SKIP <files...>])
# Static library sigmaheart_<name>, alias sigmaheart::<name>, the source root as include
# directory, the project warnings, and a unity build. Dependencies are the caller's:
# target_link_libraries(sigmaheart_<name> PUBLIC ...).
#
# Unity build (build time: docs/architecture.md s.11, experiments/build-time/NOTES.md): most of a
# source's compile time went into what every source repeats, the instantiation and code
# generation of the same Eigen, CLI11, json and fmt templates and the parsing of the same headers
# (an app/ source is ~200 000 lines after preprocessing). CMake compiles the sources in batches of
# SIGMAHEART_UNITY_BUILD_BATCH_SIZE, each batch one translation unit. File-local names (anonymous
# namespaces, static functions, constants) of sources in one batch share a scope: a source whose
# names clash with another's, or that leaves a `using namespace` or a macro behind, is listed in
# UNITY_SKIP and compiled alone. A clash is a compile error, never a silent change. Off with
# -DSIGMAHEART_UNITY_BUILD=OFF: to check that each source includes what it uses, or for
# edit-compile cycles (an edited source then recompiles alone, not its batch).
option(SIGMAHEART_UNITY_BUILD "Compile the libraries' sources in batches (unity build)" ON)
set(SIGMAHEART_UNITY_BUILD_BATCH_SIZE 8 CACHE STRING "Sources per unity batch")

function(sigmaheart_library name)
  cmake_parse_arguments(L "" "" "SOURCES;UNITY_SKIP" ${ARGN})
  set(target sigmaheart_${name})
  add_library(${target} STATIC ${L_SOURCES})
  add_library(sigmaheart::${name} ALIAS ${target})
  target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${target} PRIVATE sigmaheart_warnings)
  if(SIGMAHEART_UNITY_BUILD)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON
                          UNITY_BUILD_BATCH_SIZE ${SIGMAHEART_UNITY_BUILD_BATCH_SIZE})
    if(L_UNITY_SKIP)
      set_source_files_properties(${L_UNITY_SKIP} TARGET_DIRECTORY ${target}
                                  PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
    endif()
  endif()
endfunction()
