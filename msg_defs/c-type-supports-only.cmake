# Generate only what rclpy uses: the C code (rosidl_generator_c), the C type
# supports (rosidl_typesupport_c and the fastrtps_c and introspection_c ones it
# dispatches to), the type descriptions and the Python package. The C++ code and
# type supports (rosidl_generator_cpp, rosidl_typesupport_cpp, _fastrtps_cpp,
# _introspection_cpp) were 69 of msg_defs' 233 compile units, and nothing here
# loads them: rclpy, ros2cli and our recorder use the C ones. Each generator
# registers itself with ament_register_extension when found, by
# rosidl_default_generators or by a dependency's exported dependencies (geometry_msgs
# brings the C++ ones back), so the C++ ones are dropped from that list just
# before rosidl_generate_interfaces runs it. A C++ node that uses these messages
# needs them: -DSWAZURE_INTERFACES_CPP=ON builds them as before.
option(SWAZURE_INTERFACES_CPP "Generate the C++ code and type supports too" OFF)
macro(swazure_drop_cpp_generators)
  if(NOT SWAZURE_INTERFACES_CPP)
    list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "_cpp:")
  endif()
endmacro()
