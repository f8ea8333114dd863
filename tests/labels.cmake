# CTest labels of the GoogleTest cases, so a part of the suite can be run alone (`ctest -L unit`):
#   unit       fast, needs nothing but the build (no ../shared/data, no browser, no long scene run);
#              `ctest -L unit -j2` stays under a minute
#   scene      whole simulated-scene runs (tracking, loops, PGO over a route): seconds to a minute each
#   real-data  reads ../shared/data (HAZMAP_SHARED_DATA_DIR)
#   browser    drives headless chromium
#   python     pytest (tests/python; labelled in tests/CMakeLists.txt, as are tests/scripts)
# CTest reads this file after the tests discovered from each binary (tests/CMakeLists.txt adds it
# to TEST_INCLUDE_FILES last), so it can match their names: hazmap_label(<binary> <labels>
# [<labels> <regex>]...) gives every test of <binary> its default <labels>, then the labels of
# the last group whose regex matches "Suite.Name" (parameterised: "Prefix/Suite.Name/param").
# Labels are comma-separated. Every test binary has its line (the configure step checks).

function(hazmap_label binary default)
  foreach(test IN LISTS ${binary}_TESTS)
    set(labels "${default}")
    set(groups ${ARGN})
    while(groups)
      list(POP_FRONT groups group_labels pattern)
      if(test MATCHES "${pattern}")
        set(labels "${group_labels}")
      endif()
    endwhile()
    string(REPLACE "," ";" labels "${labels}")
    set_tests_properties("${test}" PROPERTIES LABELS "${labels}")
  endforeach()
endfunction()

hazmap_label(test_bags_mcap_writer unit)
hazmap_label(test_config unit)
hazmap_label(test_core unit)
hazmap_label(test_loop unit)
hazmap_label(test_loop_verify unit
  scene "^LoopVerify\\.DetectorClosesTheRouteLoopUnderDrift$")
hazmap_label(test_properties_map unit)
hazmap_label(test_registration unit)
hazmap_label(test_segmented_map unit)
hazmap_label(test_sim unit)
hazmap_label(test_stable_sort unit)
hazmap_label(test_live_save_map scene)
hazmap_label(test_live_view unit)
hazmap_label(test_live_view_feed unit
  scene "^LiveViewHook\\.")
hazmap_label(test_live_browser browser)
hazmap_label(test_sim_cli unit)
hazmap_label(test_back_end unit
  scene "NeverWorse|^MapSkipsFallback\\.")
hazmap_label(test_bags unit
  real-data "^Rosbag2\\.|^RosMessages\\.RealPointCloud2Cdr$")
hazmap_label(test_bags_mcap real-data
  unit "^Mcap\\.NotAnMcapFailsWithOneLine$")
hazmap_label(test_bags_ros1 unit
  real-data "^Ros1Bag\\.RealOusterBag$")
hazmap_label(test_demo_seeds unit
  scene "^DemoSeedsCli\\.|^NoiseSweepCli\\.")
hazmap_label(test_eval unit
  real-data "Kitti00|^TrajectoryMetrics\\.EvaluateTrajectoryJsonHasTheDocumentedKeys$|^EvalCli\\.")
hazmap_label(test_global_registration unit
  real-data "Kitti|ScanPair|RealVlp16|RealOuster|TooFewPointsSaySo|\\.Cli$")
hazmap_label(test_graph unit
  real-data "^GraphG2o\\.(RoundTrip3DIsExact|FileWithoutVertices)|^GraphOptimizer\\.(SmallGrids|OptimumIsStationary|TwoDimensional|InvalidConfig)|^GraphCli\\.(Optimize|YamlConfig)|^G2oIndefiniteInformation\\.")
hazmap_label(test_graph_datasets real-data)
hazmap_label(test_keyframe_graph unit)
hazmap_label(test_gravity unit
  scene "^GravityNeverWorse\\.")
hazmap_label(test_imu unit
  real-data "^OusterImu\\.Real|^ImuRun\\."
  scene "^SimImu\\.SequenceFolder")
hazmap_label(test_io unit
  real-data "^IoRealData\\.|RealScanThroughCompressedPcd|SequenceWriterThenSequence")
hazmap_label(test_io_errors unit
  real-data "^IoCli\\.|^IoErrors\\.TransformFiles$")
hazmap_label(test_label_noise scene)
hazmap_label(test_loop_schedule unit
  scene "ARunSearchesOnlyTheScheduledKeyframes|OnlineSolvesOfTheKeyframesGraph|^LoopsBesideTracking\\.")
hazmap_label(test_loop_sim scene)
hazmap_label(test_map unit
  real-data "^GlobalMapReal\\.")
hazmap_label(test_nees unit
  scene "^EdgeNeesCli\\.|^HonestOdometryEdges\\.")
hazmap_label(test_odometry unit
  real-data "^KittiSemantic\\.|KittiSample|^Cli\\.Register")
hazmap_label(test_ouster real-data
  unit "^OusterPackets\\.(Rng19|DualReturn|LegacyHandBuilt|ScansAreCut|CaptureClock|MeasurementId)")
hazmap_label(test_pcap real-data
  unit "^Pcap\\.(Snapped|BadFiles|ReadsPcapng|ReadsFromMemoryStream)")
hazmap_label(test_pipeline scene
  unit "^SlamMethod\\."
  real-data "^RunCli\\.KittiSample")
hazmap_label(test_preprocess real-data
  unit "^Preprocess\\.CropAndDownsampleRejectsBadConfig$")
hazmap_label(test_properties unit
  real-data "^BagImages\\.")
hazmap_label(test_camera_rigs unit)
hazmap_label(test_camera_real_frame real-data)
hazmap_label(test_properties_loops scene)
hazmap_label(test_properties_sim scene)
hazmap_label(test_registration_real real-data)
hazmap_label(test_tracking_stress real-data
  unit "^TrackingStress\\.HypothesesAreNotARunKey$")
hazmap_label(test_relocalise scene
  unit "^WorstDay\\.(PresetIsRead|KicksAreTrueMotion|NoOdometryFile)|^LabelAxis\\.NoLabelledPointInView|^ScanSurfaces\\."
  real-data "^Relocalise\\.(AScanWithTooFewPoints|OffLeavesAFailedFrame|KittiWith|OusterOs1128)")
hazmap_label(test_sources unit
  scene "^SlamStream\\.")
hazmap_label(test_sources_cli real-data
  scene "^SimulateMcap\\.")
hazmap_label(test_tolerant_decoding real-data)
hazmap_label(test_hesai real-data)
hazmap_label(test_velodyne real-data
  unit "^Velodyne\\.(Hdl32eBlockLayout|ExactAzimuth)|^VelodyneCalibration\\.|^VelodyneCalibrationFile\\.BadFilesAreNamed$")
hazmap_label(test_viewer unit
  browser "^ViewerBrowser\\.ShowsTheMap|^ViewerBrowser\\.ShowsTheChanges"
  "browser,scene" "^ViewerBrowser\\.RunWritesAViewer")
hazmap_label(test_background_saves unit)
hazmap_label(test_live real-data
  unit "^LiveSpool\\.WriterRoundTrips|^LiveErrors\\."
  scene "^LiveSimulated\\.")
hazmap_label(test_live_cameras unit
  real-data "^LiveCameraRealFrame\\.")
hazmap_label(test_merge unit
  scene "^MergeScene\\."
  real-data "^MergeReal\\.")
hazmap_label(test_missions unit
  scene "^PriorMap\\.SecondMission"
  real-data "^PriorMapReal\\.")
hazmap_label(test_back_end_thread scene
  unit "^(FrameLatency\\..*|AsyncBackEnd\\.QueueBoundMustBePositive)$")
