"""Names the dead-code check (vulture, ``make lint`` and ``make test``) must not report.

Each is used, but in a way vulture cannot see: called by rclpy, pytest, the
standard library or numba, read through ``dataclasses.fields``/``asdict``, a
string key or a registry. Vulture only reads this file (``_.name`` counts as a
use of ``name``); it is never imported. Entries marked ``# owner: ...`` are dead
code in that owner's area, listed here only until they remove it.
"""

# ROS: rclpy calls the lifecycle transitions of a LifecycleNode (tribo_drivers.nodes.driver_base)
_.on_configure
_.on_cleanup
_.on_shutdown
# ROS: entity handles kept on the node for its lifetime (timers, subscriptions)
_._diag_timer
_._idle_timer
_._flush_timer
_._sub
# ROS: message fields, read by the subscribers (tribo_nvct.nodes.wear_monitor)
_.wear_volume_se
_.wear_height
_.wear_height_se
_.wear_rate_se
# ROS: keyword arguments of rclpy.node.Node (tribo_common.node_main.NodeOptions)
_.cli_args
_.use_global_arguments
_.enable_rosout
_.start_parameter_services
_.parameter_overrides
_.allow_undeclared_parameters
_.automatically_declare_parameters_from_overrides
# ROS: keyword of rclpy's Executor.spin_once (tribo_common.node_main.SpinsOnce protocol)
_.timeout_sec

# Python: module-level __getattr__ / __dir__ of a package's lazy exports (PEP 562)
__getattr__
__dir__

# pytest: module-level marks
pytestmark

# standard library: argparse.Action.__call__'s argument (tribo_bringup/commands/discrepancy.py)
_.option_string
# standard library: the context-manager protocol's __exit__ arguments (core/rigio.py)
_.exc_type
# scipy: solve_ivp reads an event function's ``terminal`` attribute (core/reference.py)
_.terminal
# standard library: html.parser.HTMLParser callbacks (tribo_bringup/test/report/test_report.py)
_.handle_starttag
_.handle_endtag
_.handle_data

# numba: the overload of kernel.state.with_entry, registered by its decorator
_with_entry_numba

# registry plug-ins: each effect module's CANDIDATE, collected by discrepancy.candidates
CANDIDATE

# dataclass fields read through dataclasses.fields / asdict / __dict__
_.frame_errors  # DriverCounters.as_pairs -> /diagnostics
_.stamp_jitter_rms  # FaultReport.lines -> bench/bench_daq.py
_.f_n_hz_se  # DecayResult.to_dict -> tribo decay output
_.zeta_se  # DecayResult.to_dict

# TypedDict keys read by string subscript (tribo_bringup.report.provenance.Provenance)
_.git_commit
_.git_dirty
_.created

# pytest autouse fixtures (conftest.py): pytest calls them by itself
_sigint_restored

# pytest hooks (conftest.py)
pytest_collection_modifyitems
