"""The boundary through FMPy's low-level interface (an importer written
independently of this project): for every kind and FMI version a wrong
GUID (instantiation token) and a step that is not a whole number of
samples get a logged message and an error status; a non-finite input the
documented flag and a warning; save and restore through the FMU state
functions; two instances independent."""

import shutil

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    calloc,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    free,
)
from fmpy.fmi3 import FMU3Slave

TS = 2e-4


class Logged:
    def __init__(self):
        self.messages = []
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(self.log)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)

    def log(self, env, name, status, category, message):
        self.messages.append((status, message.decode()))


@pytest.fixture
def compensator2(fmus, tmp_path):
    d = extract(str(fmus[("compensator", "2")]), unzipdir=str(tmp_path / "unzipped"))
    yield d, read_model_description(d)
    shutil.rmtree(d, ignore_errors=True)


def slave(d, md, guid=None, name="test"):
    return FMU2Slave(guid=guid or md.guid, unzipDirectory=d,
                     modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)


def vr(md, name):
    return next(v.valueReference for v in md.modelVariables if v.name == name)


def any_fmu(fmus, kind, version, tmp_path):
    d = extract(str(fmus[(kind, version)]), unzipdir=str(tmp_path / "any"))
    return d, read_model_description(d)


def instantiated(d, md, version, logged, guid=None):
    """An instance through FMPy's class for the version; None if refused."""
    ident = md.coSimulation.modelIdentifier
    if version == "2":
        fmu = FMU2Slave(guid=guid or md.guid, unzipDirectory=d, modelIdentifier=ident, instanceName="t")
        try:
            fmu.instantiate(callbacks=logged.callbacks, loggingOn=True)
        except Exception:
            return None
        fmu.setupExperiment(startTime=0.0)
    else:
        fmu = FMU3Slave(guid=guid or md.guid, unzipDirectory=d, modelIdentifier=ident, instanceName="t")
        try:
            fmu.instantiate(loggingOn=True, logMessage=lambda env, status, cat, msg: logged.messages.append((status, msg.decode())))
        except Exception:
            return None
    return fmu


@pytest.mark.parametrize("kind", ["compensator", "model", "plant"])
@pytest.mark.parametrize("version", ["2", "3"])
def test_a_wrong_guid_and_a_fractional_step_are_logged_errors(fmus, tmp_path, kind, version):
    d, md = any_fmu(fmus, kind, version, tmp_path)
    logged = Logged()
    assert instantiated(d, md, version, logged, guid="{00000000-0000-0000-0000-000000000000}") is None
    assert any(s == 3 and "token" in m for s, m in logged.messages), logged.messages
    logged = Logged()
    fmu = instantiated(d, md, version, logged)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    with pytest.raises(FMICallException):
        fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.5 * TS)
    assert any(s == 3 and "whole multiple" in m for s, m in logged.messages), logged.messages
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=2 * TS)
    fmu.terminate()
    fmu.freeInstance()


def started(d, md, logged, name="test"):
    fmu = slave(d, md, name=name)
    fmu.instantiate(callbacks=logged.callbacks, loggingOn=True)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    return fmu


def test_a_non_finite_target_is_flagged_and_held(compensator2):
    d, md = compensator2
    logged = Logged()
    fmu = started(d, md, logged)
    y_d, u, fault = vr(md, "y_d"), vr(md, "u"), vr(md, "fault")
    fmu.setReal([y_d], [300.0])
    fmu.doStep(0.0, TS)
    held = fmu.getReal([u])[0]
    fmu.setReal([y_d], [float("nan")])
    fmu.doStep(TS, TS)  # a warning, not an error
    assert fmu.getBoolean([fault]) == [True]
    assert fmu.getReal([u])[0] == held
    assert any(s == 1 and "not a finite number" in m for s, m in logged.messages)
    fmu.terminate()
    fmu.freeInstance()


def test_state_save_restore_and_independent_instances(compensator2):
    d, md = compensator2
    y_d, u = vr(md, "y_d"), vr(md, "u")
    targets = [600.0 * ((k % 37) / 18.0 - 1.0) for k in range(120)]
    a = started(d, md, Logged(), "a")
    b = started(d, md, Logged(), "b")
    ua, state = [], None
    for k, y in enumerate(targets):
        if k == 60:
            state = a.getFMUstate()
            for j in range(11):  # a detour, then back
                a.setReal([y_d], [900.0 - 50 * j])
                a.doStep((k + j) * TS, TS)
            a.setFMUstate(state)
        a.setReal([y_d], [y])
        b.setReal([y_d], [-y])
        a.doStep(k * TS, TS)
        b.doStep(k * TS, TS)
        ua.append(a.getReal([u])[0])
        # odd symmetry from the virgin state, instance b on negated targets
        assert b.getReal([u])[0] == -ua[-1]
    a.freeFMUstate(state)
    c = started(d, md, Logged(), "c")
    uc = []
    for k, y in enumerate(targets):
        c.setReal([y_d], [y])
        c.doStep(k * TS, TS)
        uc.append(c.getReal([u])[0])
    assert ua == uc
    for f in (a, b, c):
        f.terminate()
        f.freeInstance()
