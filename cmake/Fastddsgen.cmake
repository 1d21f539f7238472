# saccade_fastddsgen(<library> <idl file>...): a static library of the C++
# that Debian's fastddsgen generates from the IDL files at build time, its
# headers on the library's include path. Generated code builds without the
# project's warning flags (it is not ours to fix).
find_program(FASTDDSGEN fastddsgen REQUIRED)

function(saccade_fastddsgen library)
  set(out ${CMAKE_CURRENT_BINARY_DIR}/${library})
  set(sources)
  foreach(idl ${ARGN})
    get_filename_component(name ${idl} NAME_WE)
    add_custom_command(
      OUTPUT ${out}/${name}.cxx ${out}/${name}PubSubTypes.cxx ${out}/${name}.h ${out}/${name}PubSubTypes.h
      COMMAND ${CMAKE_COMMAND} -E make_directory ${out}
      COMMAND ${FASTDDSGEN} -replace -d ${out} ${idl}
      DEPENDS ${idl}
      COMMENT "fastddsgen ${name}.idl"
      VERBATIM)
    list(APPEND sources ${out}/${name}.cxx ${out}/${name}PubSubTypes.cxx)
  endforeach()
  add_library(${library} STATIC ${sources})
  target_include_directories(${library} SYSTEM PUBLIC ${out})
  target_link_libraries(${library} PUBLIC fastrtps fastcdr)
endfunction()
