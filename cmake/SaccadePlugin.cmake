# saccade_add_plugin(NAME <lib> SOURCES ... [LIBS ...]
#                    [OUTPUT_DIRECTORY <dir>] [INSTALL_DESTINATION <dir>] [NO_INSTALL])
#
# Builds a plugin library: a loadable module saccade_<lib>.so that the saccade
# host finds in a plugin folder (--plugin-path, SACCADE_PLUGIN_PATH, or the
# folder its own plugins are installed in). The same function builds the
# plugins of the saccade tree and, installed with the package
# (find_package(saccade)), out-of-tree plugins, with the same flags:
#
# - MODULE, no "lib" prefix, named saccade_<lib>.so (the host loads nothing else);
# - hidden visibility (CXX_VISIBILITY_PRESET hidden, inline functions hidden
#   too): the library exports only its entry, saccade_plugin_entry, so two
#   plugins' private helpers of the same name never bind to each other;
# - GCC's -fno-gnu-unique: GCC's unique symbols (static locals of inline
#   functions, template statics) would pin the library in memory forever,
#   hiding a node that outlives its library; without them the registry's
#   library handles decide when it unloads;
# - -Wl,--no-undefined: a symbol nobody provides is a link error, not a failed
#   load at run time;
# - linked to saccade::core only (plus LIBS): plugins never link each other.
#
# OUTPUT_DIRECTORY: where the .so is built (default: <build>/plugins, one
# folder for every plugin of the project, ready for --plugin-path).
# INSTALL_DESTINATION: where `cmake --install` puts it (default:
# <libdir>/saccade/plugins, the folder an installed saccade searches beside its
# libsaccade.so). NO_INSTALL: no install rule.
function(saccade_add_plugin)
  cmake_parse_arguments(P "NO_INSTALL" "NAME;OUTPUT_DIRECTORY;INSTALL_DESTINATION" "SOURCES;LIBS" ${ARGN})
  if(NOT P_NAME OR NOT P_NAME MATCHES "^[A-Za-z0-9_]+$")
    message(FATAL_ERROR "saccade_add_plugin: NAME must be letters, digits and '_' (got '${P_NAME}')")
  endif()
  if(NOT P_SOURCES)
    message(FATAL_ERROR "saccade_add_plugin(NAME ${P_NAME}): no SOURCES")
  endif()
  if(NOT P_OUTPUT_DIRECTORY)
    if(SACCADE_PLUGIN_BUILD_DIR)
      set(P_OUTPUT_DIRECTORY ${SACCADE_PLUGIN_BUILD_DIR})
    else()
      set(P_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/plugins)
    endif()
  endif()
  if(NOT P_INSTALL_DESTINATION)
    include(GNUInstallDirs)
    set(P_INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/saccade/plugins)
  endif()

  set(target saccade_plugin_${P_NAME})
  add_library(${target} MODULE ${P_SOURCES})
  set_property(GLOBAL APPEND PROPERTY SACCADE_PLUGIN_TARGETS ${target})  # every plugin of the project
  set_target_properties(${target} PROPERTIES
    PREFIX "" SUFFIX ".so" OUTPUT_NAME saccade_${P_NAME}
    LIBRARY_OUTPUT_DIRECTORY ${P_OUTPUT_DIRECTORY}
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON
    # Installed in <libdir>/saccade/plugins: libsaccade.so is two folders up.
    INSTALL_RPATH "$ORIGIN/../..")
  target_compile_features(${target} PRIVATE cxx_std_20)
  target_link_libraries(${target} PRIVATE saccade::core ${P_LIBS})
  if(TARGET saccade_warnings)  # the saccade tree's own warning flags
    target_link_libraries(${target} PRIVATE saccade_warnings)
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -fno-gnu-unique)
  endif()
  target_link_options(${target} PRIVATE -Wl,--no-undefined)
  if(NOT P_NO_INSTALL)
    install(TARGETS ${target} LIBRARY DESTINATION ${P_INSTALL_DESTINATION})
  endif()
endfunction()
