"""The controller manager's name and call timeout as ``ros2 control`` defaults them: constants
the command line shows in its help, kept apart from the manager so ``--help`` imports no
middleware."""

#: the controller manager's default name, as ros2controlcli's ``-c`` defaults it
DEFAULT_MANAGER = "/controller_manager"
#: s a service call waits for its answer (the spawner's --service-call-timeout)
CALL_TIMEOUT = 10.0
