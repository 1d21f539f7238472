# saccade_add_plugin(NAME <lib> SOURCES ... [LIBS ...])
# Builds plugins/<lib> as a loadable module named saccade_<lib>.so in the plugin
# folder. -fno-gnu-unique keeps GCC's unique symbols from pinning the library in
# memory, so a node outliving its library would crash in tests rather than hide.
function(saccade_add_plugin)
  cmake_parse_arguments(P "" "NAME" "SOURCES;LIBS" ${ARGN})
  set(target saccade_plugin_${P_NAME})
  add_library(${target} MODULE ${P_SOURCES})
  set_target_properties(${target} PROPERTIES
    PREFIX "" OUTPUT_NAME saccade_${P_NAME}
    LIBRARY_OUTPUT_DIRECTORY ${SACCADE_PLUGIN_BUILD_DIR}
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  target_link_libraries(${target} PRIVATE saccade::core saccade_warnings ${P_LIBS})
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -fno-gnu-unique)
  endif()
  target_link_options(${target} PRIVATE -Wl,--no-undefined)
  install(TARGETS ${target} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/saccade/plugins)
endfunction()
