# N-DAM tests (included from tests/CMakeLists.txt). Serial GoogleTest cases are discovered one by
# one; the MPI comparison runs the same binary family under mpiexec with 2 ranks.
add_executable(test_ndam
  ${CMAKE_CURRENT_LIST_DIR}/ndam_main.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_ndam_verification.cpp
)
target_link_libraries(test_ndam PRIVATE granflow_ndam granflow_scene GTest::gtest granflow_warnings)
target_compile_definitions(test_ndam PRIVATE GRANFLOW_INPUTS="${PROJECT_SOURCE_DIR}/inputs")
# The long cases (finer cavity grids, Re = 1000) are registered separately with the label `long`.
gtest_discover_tests(test_ndam DISCOVERY_TIMEOUT 60 TEST_FILTER "-NdamCavityLong.*:NdamPlugLong.*:NdamDepositLong.*"
                     PROPERTIES LABELS "ndam")
add_test(NAME ndam.cavity_long COMMAND test_ndam --gtest_filter=NdamCavityLong.*)
set_tests_properties(ndam.cavity_long PROPERTIES LABELS "ndam;long" TIMEOUT 3600)
add_test(NAME ndam.plug_long COMMAND test_ndam --gtest_filter=NdamPlugLong.*)
set_tests_properties(ndam.plug_long PROPERTIES LABELS "ndam;long" TIMEOUT 600)
add_test(NAME ndam.deposit_long COMMAND test_ndam --gtest_filter=NdamDepositLong.*)
set_tests_properties(ndam.deposit_long PROPERTIES LABELS "ndam;long" TIMEOUT 900)

# np = 2 against np = 1: the distributed run and a serial run (MPI_COMM_SELF) inside one binary
# under mpiexec with 2 ranks (as root OpenMPI needs --allow-run-as-root; 2 ranks on 2 cores
# need no oversubscription, but the flag keeps the test runnable on 1-core CI machines).
add_executable(test_ndam_mpi
  ${CMAKE_CURRENT_LIST_DIR}/ndam_main.cpp
  ${CMAKE_CURRENT_LIST_DIR}/test_ndam_mpi.cpp
)
target_link_libraries(test_ndam_mpi PRIVATE granflow_ndam GTest::gtest granflow_warnings)
add_test(NAME ndam.mpi_np2_equals_np1
         COMMAND ${MPIEXEC_EXECUTABLE} ${MPIEXEC_NUMPROC_FLAG} 2 --allow-run-as-root
                 --oversubscribe $<TARGET_FILE:test_ndam_mpi>)
set_tests_properties(ndam.mpi_np2_equals_np1 PROPERTIES LABELS "ndam;mpi" TIMEOUT 300
                     PROCESSORS 2)

# The XML interface under MPI: the app runs a 2D scene on 2 ranks (x-slabs) and completes; only
# rank 0 writes the run directory (in the build tree).
add_test(NAME ndam.app_rest_slope_np2
         COMMAND ${MPIEXEC_EXECUTABLE} ${MPIEXEC_NUMPROC_FLAG} 2 --allow-run-as-root
                 --oversubscribe $<TARGET_FILE:granflow>
                 ${PROJECT_SOURCE_DIR}/inputs/ndam_rest_slope.xml
         WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(ndam.app_rest_slope_np2 PROPERTIES LABELS "ndam;mpi" TIMEOUT 120
                     PROCESSORS 2)

# Free surface, Coulomb sliding, chute boundaries (issue 4).
target_sources(test_ndam PRIVATE ${CMAKE_CURRENT_LIST_DIR}/test_ndam_chute.cpp
                               ${CMAKE_CURRENT_LIST_DIR}/test_ndam_newton.cpp
                               ${CMAKE_CURRENT_LIST_DIR}/test_ndam_wall.cpp
                               ${CMAKE_CURRENT_LIST_DIR}/test_ndam_ghost.cpp)
