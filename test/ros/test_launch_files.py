#!/usr/bin/env python3
"""The launch files as roslaunch reads them (no master): what a user's command line gives.

- replay.launch bag:=pair.bag (a path relative to the user's shell) plays $PWD/pair.bag: rosbag
  play runs in ROS_HOME, where a relative path does not resolve;
- replay.launch ends when calibration_node or rosbag play ends (required), so that a bag that
  does not open or an impossible parameter ends the launch with the node's message last, instead
  of idle nodes waiting for data;
- calibration.launch passes remote_topic to calibration_node.
"""
import argparse
import os
import sys
import unittest

import roslaunch.config
import rosunit


class LaunchFiles(unittest.TestCase):
    launch_dir = None

    def load(self, name, *args):
        path = os.path.join(self.launch_dir, name)
        return roslaunch.config.load_config_default([(path, list(args))], None, verbose=False)

    def node(self, config, type_name):
        nodes = [n for n in config.nodes if n.type == type_name]
        self.assertEqual(len(nodes), 1, type_name)
        return nodes[0]

    def test_relative_bag_is_made_absolute(self):
        config = self.load("replay.launch", "bag:=pair.bag")
        play = self.node(config, "play")
        self.assertIn(os.path.join(os.environ.get("PWD", "."), "pair.bag"), play.args.split())
        config = self.load("replay.launch", "bag:=/data/pair.bag")
        self.assertIn("/data/pair.bag", self.node(config, "play").args.split())

    def test_replay_ends_when_its_nodes_end(self):
        config = self.load("replay.launch", "bag:=pair.bag")
        self.assertTrue(self.node(config, "play").required)
        self.assertTrue(self.node(config, "calibration_node").required)
        config = self.load("replay.launch", "bag:=pair.bag", "required:=false")
        self.assertFalse(self.node(config, "calibration_node").required)

    def test_remote_topic_reaches_the_calibration_node(self):
        config = self.load("replay.launch", "bag:=pair.bag", "remote_topic:=/remote/magnetic_field")
        self.assertEqual(config.params["/calibration_test/remote_topic"].value, "/remote/magnetic_field")
        self.assertIn("/remote/magnetic_field", self.node(config, "play").args.split())


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--launch-dir", required=True)
    parser.add_argument("--xml")
    options = parser.parse_args()
    LaunchFiles.launch_dir = options.launch_dir
    if options.xml:  # rosunit writes the JUnit XML where catkin's run_tests looks for it
        rosunit.unitrun("magnetometer_insitu_calibration", "launch_files", LaunchFiles,
                        sysargs=["--gtest_output=xml:" + options.xml])
    else:
        unittest.main(argv=[sys.argv[0]])
