"""Data-stream QoS (re-exported from :mod:`tribo_common.qos`, the one place that builds it)."""

from tribo_common.qos import data_qos, status_qos

__all__ = ['data_qos', 'status_qos']
