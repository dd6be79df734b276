# lcv_add_module(<target> DIR <dir> [DEPS <targets...>] [PRIVATE_DEPS <targets...>])
#
# One library per source folder (STYLE.md 1): the sources are the folder's *.cc files, globbed so
# that adding a file needs no CMake edit. A folder with no sources yet becomes an INTERFACE
# target so that dependants can already name it. Heavy dependencies (PCL, VTK, OSMesa, OpenGV)
# belong in PRIVATE_DEPS so that they never reach a public header.
function(lcv_add_module target)
  cmake_parse_arguments(ARG "" "DIR" "DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB sources CONFIGURE_DEPENDS "${ARG_DIR}/*.cc")
  if(sources)
    add_library(${target} STATIC ${sources})
    target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR})
    target_link_libraries(${target} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  else()
    add_library(${target} INTERFACE)
    target_include_directories(${target} INTERFACE ${PROJECT_SOURCE_DIR})
    target_link_libraries(${target} INTERFACE ${ARG_DEPS})
  endif()
endfunction()
