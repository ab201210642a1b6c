#!/usr/bin/env python3
"""The launch files as roslaunch reads them (no master): what a user's command line gives.

- replay.launch bag:=pair.bag (a path relative to the folder roslaunch runs in) plays that
  folder's pair.bag, whatever the environment variable PWD says (a script's subprocess started
  in another folder inherits it): rosbag play runs in ROS_HOME, where a relative path does not
  resolve;
- replay.launch ends when calibration_node or rosbag play ends (required), so that a bag that
  does not open or an impossible parameter ends the launch with the node's message last, instead
  of idle nodes waiting for data;
- calibration.launch passes remote_topic to calibration_node, and so does station.launch; one
  given in calibration_params is kept;
- station.launch and network.launch remote_files:=GLOB start record_file_follower on the topic
  that calibration_node's remote_topic names, and no follower without it;
- replay.launch plays the test's temperature and gives it to both nodes;
- each run of simulated_station.launch writes its own calibration file (a second run does not
  find the first one's, a calibration of later data);
- every `rostopic echo` in the README's quick start names a topic that the roslaunch command
  before it (in the same code block, with the same arguments) publishes;
- simulated_station.launch: a duration plays the record once and ends the launch (simulators
  required, no --loop); without one the record loops and nothing ends the launch; the same for
  simulated_network.launch's five simulators;
- simulated_network.launch: station a's three instruments see one field (one field seed) with
  three noises (three seeds), as the three-cornered hat needs; station b sees station a's field
  only with shared_field;
- simulated_station.launch ends when calibration_node ends (an impossible parameter); station.launch
  only with calibration_required:=true;
- calibration_node writes to the screen by default (one line per window on the console: with
  output=log roslaunch sends a node's stdout, where ROS_INFO goes, to a file).
"""
import argparse
import os
import re
import shlex
import subprocess
import sys
import tempfile
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

    def replay_bag(self, bag, cwd, pwd):
        """The bag replay.launch plays (its player's ~bag) as roslaunch resolves it in a process
        started in folder `cwd` with the environment variable PWD set to `pwd`."""
        script = ("import sys, roslaunch.config\n"
                  "c = roslaunch.config.load_config_default([(sys.argv[1], sys.argv[2:])], None, verbose=False)\n"
                  "sys.stdout.write(c.params['/replay_test/bag'].value)\n")
        path = os.path.abspath(os.path.join(self.launch_dir, "replay.launch"))
        run = subprocess.run([sys.executable, "-c", script, path, "bag:=" + bag], cwd=cwd, env=dict(os.environ, PWD=pwd),
                             stdout=subprocess.PIPE, universal_newlines=True, check=True)
        return run.stdout.rstrip("\n")

    def test_relative_bag_is_relative_to_the_working_directory(self):
        with tempfile.TemporaryDirectory() as cwd, tempfile.TemporaryDirectory() as pwd:
            real_cwd = os.path.realpath(cwd)
            self.assertEqual(self.replay_bag("records/pair.bag", cwd, pwd), os.path.join(real_cwd, "records", "pair.bag"))
            self.assertEqual(self.replay_bag("/data/pair.bag", cwd, pwd), "/data/pair.bag")
        play = self.node(self.load("replay.launch", "bag:=pair.bag"), "play_bag")
        self.assertNotIn("pair.bag", play.args)  # the player's only bag is ~bag

    def test_replay_ends_when_its_nodes_end(self):
        config = self.load("replay.launch", "bag:=pair.bag")
        self.assertTrue(self.node(config, "play_bag").required)
        self.assertTrue(self.node(config, "calibration_node").required)
        config = self.load("replay.launch", "bag:=pair.bag", "required:=false")
        self.assertFalse(self.node(config, "calibration_node").required)

    def test_remote_topic_reaches_the_calibration_node(self):
        config = self.load("replay.launch", "bag:=pair.bag", "remote_topic:=/remote/magnetic_field")
        self.assertEqual(config.params["/calibration_test/remote_topic"].value, "/remote/magnetic_field")
        self.assertIn("/remote/magnetic_field", self.node(config, "play_bag").args.split())

    def test_replay_plays_the_test_temperature(self):
        # records_to_bag writes the driver's topic names: a station's bag and an archive's replay
        # alike, the temperature reaching both nodes and played by rosbag play.
        config = self.load("replay.launch", "bag:=pair.bag", "temperature_topic:=/test/temperature/sensor")
        self.assertEqual(config.params["/calibration_test/temperature_topic"].value, "/test/temperature/sensor")
        self.assertEqual(config.params["/correction_test/temperature_topic"].value, "/test/temperature/sensor")
        self.assertIn("/test/temperature/sensor", self.node(config, "play_bag").args.split())

    def test_station_takes_a_remote_topic(self):
        # The README's station command with a remote: the argument reaches the node (it was
        # silently dropped), and a remote_topic in calibration_params is no longer overwritten.
        config = self.load("station.launch", "remote_topic:=/remote/magnetic_field")
        self.assertEqual(config.params["/calibration_test/remote_topic"].value, "/remote/magnetic_field")
        config = self.load("station.launch", "calibration_params:={input_period: 0.1, remote_topic: /obs2/field}")
        self.assertEqual(config.params["/calibration_test/remote_topic"].value, "/obs2/field")
        config = self.load("station.launch")  # not set: the node's default, none
        self.assertNotIn("/calibration_test/remote_topic", config.params)

    def test_remote_files_start_a_follower_on_the_remote_topic(self):
        # station.launch and network.launch remote_files:=GLOB: record_file_follower follows the
        # files and publishes on the topic calibration_node takes as its remote_topic.
        config = self.load("station.launch", "remote_files:=/data/obs2/*.sec")
        follower = self.node(config, "record_file_follower")
        prefix = follower.namespace + follower.name + "/"
        self.assertEqual(config.params[prefix + "path"].value, "/data/obs2/*.sec")
        self.assertEqual(config.params[prefix + "topic"].value, "/remote/magnetic_field")
        self.assertEqual(config.params["/calibration_test/remote_topic"].value, "/remote/magnetic_field")
        config = self.load("station.launch", "remote_files:=/data/obs2", "remote_topic:=/obs2/field")
        follower = self.node(config, "record_file_follower")
        self.assertEqual(config.params[follower.namespace + follower.name + "/topic"].value, "/obs2/field")
        self.assertEqual(config.params["/calibration_test/remote_topic"].value, "/obs2/field")
        for name in ("station.launch", "network.launch"):
            config = self.load(name)
            self.assertEqual([n for n in config.nodes if n.type == "record_file_follower"], [], name)
        config = self.load("network.launch", "station:=wic", "remote_files:=/data/obs2/*.sec")
        follower = self.node(config, "record_file_follower")
        self.assertEqual(follower.namespace, "/wic/")
        self.assertEqual(config.params["/wic/remote_files/topic"].value, "remote/magnetic_field")
        self.assertEqual(config.params["/wic/calibration/remote_topic"].value, "remote/magnetic_field")

    def test_each_simulated_station_run_has_its_own_calibration_file(self):
        # A second run of the simulated station must not find the first run's file (a
        # calibration of later data, refused by the correction node with an error).
        files = [self.load("simulated_station.launch", "duration:=3000").params["/calibration_test/calibration_file"].value
                 for _ in range(2)]
        self.assertNotEqual(files[0], files[1])
        config = self.load("simulated_station.launch", "calibration_file:=/data/fge.yaml")
        self.assertEqual(config.params["/calibration_test/calibration_file"].value, "/data/fge.yaml")
        self.assertEqual(config.params["/correction_test/calibration_file"].value, "/data/fge.yaml")

    def published_topics(self, config):
        """Topics the launched nodes publish: each driver's magnetic_field in its namespace,
        calibration_node's and correction_node's output topics as their parameters give them."""
        topics = set()
        for n in config.nodes:
            if n.type == "lemi025_driver":
                topics.add(n.namespace + "magnetic_field")
        for name, p in config.params.items():
            if name.endswith("/calibration_topic") or name.endswith("/corrected_topic"):
                topics.add(p.value)
        return topics

    def test_readme_echoes_topics_its_launch_commands_publish(self):
        with open(os.path.join(os.path.dirname(self.launch_dir), "README.md")) as f:
            readme = f.read()
        blocks = re.findall(r"(?:^    .*\n)+", readme, re.M)  # indented code blocks
        echoes = 0
        for block in blocks:
            launch_args = None
            for command in block.replace("\\\n", " ").splitlines():
                words = shlex.split(command, comments=True)
                if words[:2] == ["roslaunch", "magnetometer_insitu_calibration"]:
                    launch_args = (words[2], [w for w in words[3:] if ":=" in w])
                elif words[:2] == ["rostopic", "echo"]:
                    self.assertIsNotNone(launch_args, "README: %r follows no roslaunch" % command)
                    config = self.load(launch_args[0], *launch_args[1])
                    topics = self.published_topics(config)
                    self.assertIn(words[2], topics, "README: %r after %s" % (command, launch_args[0]))
                    echoes += 1
        self.assertGreaterEqual(echoes, 2)  # the station and the simulated station

    def simulators(self, config):
        nodes = [n for n in config.nodes if n.type == "lemi025_simulator"]
        self.assertEqual(len(nodes), 2)
        return nodes

    def test_a_duration_ends_the_simulated_station(self):
        for sim in self.simulators(self.load("simulated_station.launch", "duration:=3000")):
            self.assertIn("--duration 3000", sim.args)
            self.assertNotIn("--loop", sim.args.split())
            self.assertTrue(sim.required)  # the launch ends when the record does
        for sim in self.simulators(self.load("simulated_station.launch")):
            self.assertIn("--duration 21600", sim.args)
            self.assertIn("--loop", sim.args.split())
            self.assertFalse(sim.required)
        config = self.load("simulated_station.launch", "duration:=3000", "end_with_record:=false")
        for sim in self.simulators(config):
            self.assertFalse(sim.required)

    def test_the_simulated_station_ends_with_its_calibration_node(self):
        # An impossible calibration parameter kills calibration_node at start: the simulated
        # station ends with it instead of playing its record to nobody; a real station's drivers
        # keep recording unless asked (calibration_required).
        for args in ([], ["duration:=3000"], ["nodelet_manager:=sim_manager"]):
            config = self.load("simulated_station.launch", *args)
            nodes = [n for n in config.nodes if n.name == "calibration_test"]
            self.assertEqual(len(nodes), 1, args)
            self.assertTrue(nodes[0].required, args)
        self.assertFalse(self.node(self.load("station.launch"), "calibration_node").required)
        config = self.load("station.launch", "calibration_required:=true")
        self.assertTrue(self.node(config, "calibration_node").required)

    def test_a_duration_ends_the_simulated_network(self):
        def simulators(config):
            nodes = [n for n in config.nodes if n.type == "lemi025_simulator"]
            self.assertEqual(len(nodes), 5)
            return nodes
        for sim in simulators(self.load("simulated_network.launch", "duration:=3000")):
            self.assertIn("--duration 3000", sim.args)
            self.assertNotIn("--loop", sim.args.split())
            self.assertTrue(sim.required)
        for sim in simulators(self.load("simulated_network.launch")):
            self.assertIn("--duration 21600", sim.args)
            self.assertIn("--loop", sim.args.split())
            self.assertFalse(sim.required)

    def test_simulated_network_station_a_has_three_noises_on_one_field(self):
        def option(sim, name):
            words = sim.args.split()
            return words[words.index(name) + 1] if name in words else None
        for args in ([], ["shared_field:=true"], ["seed_a:=7", "seed_b:=8"]):
            config = self.load("simulated_network.launch", *args)
            sims = {n.name: n for n in config.nodes if n.type == "lemi025_simulator"}
            station_a = [sims["simulator_a_" + name] for name in ("reference", "t1", "t2")]
            seed_a = option(sims["simulator_a_reference"], "--seed")
            self.assertEqual({option(sim, "--field-seed") for sim in station_a}, {seed_a}, args)
            self.assertNotEqual(option(sims["simulator_a_t1"], "--seed"), option(sims["simulator_a_t2"], "--seed"), args)
            shared = "shared_field:=true" in args
            for name in ("simulator_b_reference", "simulator_b_t1"):
                self.assertEqual(option(sims[name], "--field-seed"), seed_a if shared else None, (args, name))

    def test_calibration_node_prints_its_windows_on_the_console(self):
        for name, args in (("station.launch", []), ("simulated_station.launch", []), ("replay.launch", ["bag:=b.bag"]),
                           ("network.launch", ["station:=obs", "tests:=fge"])):
            config = self.load(name, *args)
            self.assertEqual(self.node(config, "calibration_node").output, "screen", name)
        config = self.load("station.launch", "calibration_output:=log")
        self.assertEqual(self.node(config, "calibration_node").output, "log")


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
