# The project include with which scripts/install_launch.sh builds launch_ros's
# composition_interfaces unchanged: as msg_defs, only the code rclpy uses (no C++
# code or type supports; msg_defs/c-type-supports-only.cmake says why). The
# package's rosidl_generate_interfaces is wrapped to drop the C++ generators first.
find_package(rosidl_cmake REQUIRED)
include(${CMAKE_CURRENT_LIST_DIR}/../msg_defs/c-type-supports-only.cmake)
macro(rosidl_generate_interfaces)
  swazure_drop_cpp_generators()
  _rosidl_generate_interfaces(${ARGN})
endmacro()
